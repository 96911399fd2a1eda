"""Cutting a long track into overlapping windows and stitching hypotheses back into one motion each.

Windows of F frames start every ``F - O`` frames (O = overlap <= F / 2), the last one
padded past the end. Windows are sampled in order. The first :func:`anchored_frames` (two)
of each window are anchored to (in-painted from) hypothesis k of the window before, and
the later window takes every overlap frame after them (:func:`blend_weights`: no ramp), so
hypothesis k is one continuous motion. (Sampling windows independently and bridging them
does not work with one camera: independent windows put hypothesis k at different depths,
and a bridge has to jump.)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from platypose.lifting.sampling.sampler import window_key


@dataclass(frozen=True)
class WindowPlan:
    """Window starts over ``total`` frames, each ``length`` long, consecutive ones sharing ``overlap`` frames."""

    total: int
    length: int
    overlap: int
    starts: np.ndarray

    @property
    def count(self) -> int:
        """Number of windows."""
        return len(self.starts)

    @property
    def padded_total(self) -> int:
        """Frames covered including the padding of the last window."""
        return int(self.starts[-1]) + self.length


def plan_windows(total: int, length: int, overlap: int) -> WindowPlan:
    """Windows covering ``total`` frames; a track shorter than ``length`` is one window of its own length."""
    if total < 1:
        raise ValueError("nothing to cut: the track has no frames")
    if length < 2 and total > 1:
        raise ValueError(f"window length must be at least 2 frames, got {length}")
    if total <= length:
        return WindowPlan(total, total, 0, np.array([0]))
    if not 0 < overlap <= length // 2:
        raise ValueError(f"overlap must be in 1..{length // 2} for windows of {length} frames, got {overlap}")
    stride = length - overlap
    count = int(np.ceil((total - length) / stride)) + 1
    return WindowPlan(total, length, overlap, np.arange(count) * stride)


def cut(values: np.ndarray, plan: WindowPlan, axis: int, fill: float = np.nan) -> np.ndarray:
    """Windows of ``values`` along ``axis`` (frames), stacked in a new leading axis ``(W, ...)``; padding = ``fill``."""
    values = np.moveaxis(values, axis, 0)
    pad = plan.padded_total - values.shape[0]
    if pad > 0:
        values = np.concatenate([values, np.full((pad, *values.shape[1:]), fill, dtype=values.dtype)])
    windows = np.stack([values[s : s + plan.length] for s in plan.starts])
    return np.moveaxis(windows, 1, axis + 1)


def blend_weights(plan: WindowPlan) -> np.ndarray:
    """Per-window frame weights ``(W, F)`` that sum to 1 over windows at every frame.

    In an overlap the earlier window keeps the frames the later one is anchored to, and the later
    window takes every frame after them: it starts on the earlier window's path (the anchor) and
    continues it as one motion of the prior. Blending the two over the overlap instead would mix the
    earlier window's last frames, which are pulled back to the rays' own placement
    (:func:`platypose.lifting.sampling.placement.continuation_ramp`), into the later window, and with one camera
    hypotheses then step at seams (docs/results.md, 2026-12-01).
    """
    weights = np.ones((plan.count, plan.length))
    if plan.count > 1:
        later = np.zeros(plan.overlap)
        later[anchored_frames(plan) :] = 1.0
        weights[1:, : plan.overlap] = later
        weights[:-1, plan.length - plan.overlap :] = 1 - later
    return weights


def anchored_frames(plan: WindowPlan) -> int:
    """How many of a window's first frames are anchored to the window before: two (position and velocity).

    Anchoring more of the overlap makes one-view hypotheses step faster at seams than inside
    windows, and fewer cannot carry the velocity over (docs/results.md, 2026-12-01).
    """
    return min(2, plan.overlap)


def stitch(windows: np.ndarray, plan: WindowPlan) -> np.ndarray:
    """Blend per-window values ``(W, F, ...)`` into one sequence ``(total, ...)``."""
    weights = blend_weights(plan)
    out = np.zeros((plan.padded_total, *windows.shape[2:]), dtype=np.float64)
    for w, start in enumerate(plan.starts):
        shape = (plan.length,) + (1,) * (windows.ndim - 2)
        out[start : start + plan.length] += weights[w].reshape(shape) * windows[w]
    return out[: plan.total]


def continuation_anchor(previous: np.ndarray, plan: WindowPlan) -> tuple[np.ndarray, np.ndarray]:
    """Anchor joints ``(..., F, 17, 3)`` and mask ``(F,)`` continuing the previous window ``(..., F, 17, 3)``.

    The previous window's last ``overlap`` frames become the new window's first ones; the
    mask holds the first :func:`anchored_frames` of them.
    """
    overlap, length = plan.overlap, plan.length
    anchor = np.zeros_like(previous)
    anchor[..., :overlap, :, :] = previous[..., length - overlap :, :, :]
    mask = np.zeros(length)
    mask[: anchored_frames(plan)] = 1.0
    return anchor, mask


@dataclass(frozen=True)
class WindowKeys:
    """The noise keys of a lift's windows: the sampler's ``seed``, each person's identity (``identities`` (P,)) and
    each window's first frame on the prior's ``clock`` (seconds, at ``fps``), counted from time 0, so that a piece of
    a take keys a window as the whole take does."""

    seed: int
    identities: Sequence[int]
    clock: np.ndarray
    fps: float

    def key(self, person: int, start: int) -> int:
        """The key (:func:`platypose.lifting.sampling.sampler.window_key`) of ``person``'s window starting at
        clock frame ``start``."""
        return window_key(self.seed, int(self.identities[person]), int(round(float(self.clock[start]) * self.fps)))
