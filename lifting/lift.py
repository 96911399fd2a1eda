"""Lifting whole tracks: resample to the prior's rate, sample windows in batches, stitch, resample back.

Input is 2D keypoints of P persons seen by C calibrated cameras on one clock;
output is N hypotheses per person at the input's frame times, each one
continuous motion across windows (see :mod:`lifting.windows`). Each window's
persons and hypotheses go through the network as one batch. Results stream out
(:func:`lift_stream`) as soon as no later window changes them, so memory does
not grow with the track's length.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError
from platypose.lifting.prior import PriorBundle
from platypose.lifting.sampler import Anchor, SamplerConfig, SampleResult, cameras_and_rays, sample
from platypose.lifting.timebase import blend_samples, interpolate, interpolation_weights
from platypose.lifting.windows import WindowPlan, blend_weights, continuation_anchor, plan_windows


@dataclass(frozen=True)
class WindowSettings:
    """Window length and overlap (prior frames) and the weight of the overlap anchors."""

    window: int = 64
    overlap: int = 16
    anchor_weight: float = 100.0

    def __post_init__(self) -> None:
        if self.window < 2 or not 0 <= self.overlap <= self.window // 2:
            raise InputError(
                f"window must be >= 2 and overlap in 0..window/2, got {self.window} and {self.overlap}", option="window"
            )
        if self.anchor_weight < 0:
            raise InputError(f"anchor weight must be >= 0, got {self.anchor_weight}")


@dataclass(frozen=True)
class LiftOutput:
    """``hypotheses`` (P, N, T, 17, 3) world metres and per-frame reprojection ``energy`` (P, N, T)."""

    hypotheses: np.ndarray
    energy: np.ndarray


@dataclass(frozen=True)
class LiftChunk:
    """Final frames ``start .. start + t`` of every person: ``hypotheses`` (P, N, t, 17, 3), ``energy`` (P, N, t)."""

    start: int
    hypotheses: np.ndarray
    energy: np.ndarray


def prior_clock(frame_times: np.ndarray, fps: float) -> np.ndarray:
    """Times at the prior's rate spanning ``frame_times``, ``(T',)``."""
    start, end = float(frame_times[0]), float(frame_times[-1])
    return start + np.arange(int(np.floor((end - start) * fps + 1e-6)) + 1) / fps


def resample_keypoints(keypoints: np.ndarray, times: np.ndarray, new_times: np.ndarray) -> np.ndarray:
    """Keypoints ``(T, ..., 3)`` (x, y, confidence; NaN or confidence 0 = missing) onto ``new_times``.

    A resampled keypoint is missing unless both neighbouring samples are present.
    """
    if len(times) == 1:  # every new time takes the one sample
        zeros = np.zeros(len(new_times), dtype=np.intp)
        return resample_keypoints_at(np.concatenate([keypoints, keypoints]), zeros, zeros.astype(np.float64))
    return resample_keypoints_at(keypoints, *interpolation_weights(times, new_times))


def resample_keypoints_at(keypoints: np.ndarray, idx: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Keypoints ``(T, ..., 3)`` at samples ``idx`` (T',) blended with ``idx + 1`` by ``w`` (T',): ``(T', ..., 3)``."""
    present = (np.isfinite(keypoints).all(-1) & (keypoints[..., 2] > 0)).astype(np.float64)
    filled = np.where(present[..., None] > 0, keypoints, 0.0)
    values = blend_samples(filled, idx, w)
    valid = blend_samples(present, idx, w) > 1 - 1e-9
    values[..., 2] = np.where(valid, values[..., 2], 0.0)
    values[..., :2] = np.where(valid[..., None], values[..., :2], np.nan)
    return values


def lift_stream(
    prior: PriorBundle,
    cameras: Sequence[Camera],
    keypoints: np.ndarray,
    frame_times: np.ndarray,
    config: SamplerConfig,
    settings: WindowSettings = WindowSettings(),
    root_trajectory: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Iterator[LiftChunk]:
    """Lift P persons' keypoints ``(C, T, P, 17, 3)`` seen by ``cameras`` at ``frame_times`` ``(T,)``, in chunks.

    Chunks come in frame order as soon as no later window can change their frames, so
    memory holds a few windows whatever the length. ``root_trajectory`` (P, T, 3), if
    known, fixes each person's pelvis path. ``progress(done, total)`` counts windows.
    """
    clock = prior_clock(frame_times, prior.fps)
    length = min(settings.window, prior.config.max_frames)
    plan = plan_windows(len(clock), length, min(settings.overlap, length // 2))
    per_window = KeypointWindows(keypoints, frame_times, clock, plan)  # [w]: (C, P, F, 17, 3)
    roots = None
    if root_trajectory is not None:
        path = interpolate(np.moveaxis(root_trajectory, 1, 0), frame_times, clock)  # (T', P, 3)
        roots = WindowView(np.moveaxis(path, 1, 0), plan, axis=1)  # [w]: (P, F, 3)
    runner = _WindowRunner(prior, list(cameras), per_window, roots, config, settings, plan, progress)
    stitcher = StreamingStitch(plan, clock, np.asarray(frame_times, dtype=np.float64))
    previous = None
    for w in range(plan.count):
        anchor = continuation_anchor(previous, plan) if previous is not None else None
        result = runner.run(w, anchor)
        previous = np.asarray(result.fitted, dtype=np.float32)  # (P, N, F, 17, 3): the next window continues the fit
        joints = np.asarray(result.joints, dtype=np.float32)
        window = (np.moveaxis(joints, 2, 0), np.moveaxis(np.asarray(result.energy, dtype=np.float32), 2, 0))
        for start, (hypotheses, frame_energy) in stitcher.add(w, window):
            yield LiftChunk(start, np.moveaxis(hypotheses, 0, 2), np.moveaxis(frame_energy, 0, 2))


def lift_tracks(
    prior: PriorBundle,
    cameras: Sequence[Camera],
    keypoints: np.ndarray,
    frame_times: np.ndarray,
    config: SamplerConfig,
    settings: WindowSettings = WindowSettings(),
    root_trajectory: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> LiftOutput:
    """:func:`lift_stream` gathered into whole arrays (for short inputs and tests)."""
    chunks = list(lift_stream(prior, cameras, keypoints, frame_times, config, settings, root_trajectory, progress))
    return LiftOutput(
        hypotheses=np.concatenate([c.hypotheses for c in chunks], axis=2),
        energy=np.concatenate([c.energy for c in chunks], axis=2),
    )


class KeypointWindows:
    """Window ``w``'s keypoints ``(C, P, F, 17, 3)`` on the prior's clock, resampled when the window is asked for.

    The same numbers as resampling the whole track with :func:`resample_keypoints` and
    cutting it into windows (NaN past the end), without a resampled copy of a long track.
    """

    def __init__(self, keypoints: np.ndarray, frame_times: np.ndarray, clock: np.ndarray, plan: WindowPlan) -> None:
        frames = np.moveaxis(keypoints, 1, 0)  # (T, C, P, 17, 3)
        if len(frame_times) == 1:  # as resample_keypoints: every prior frame takes the one sample
            frames = np.concatenate([frames, frames])
            self.idx, self.w = np.zeros(len(clock), np.intp), np.zeros(len(clock))
        else:
            self.idx, self.w = interpolation_weights(frame_times, clock)
        self.frames, self.plan = frames, plan

    def __len__(self) -> int:
        return self.plan.count

    def __getitem__(self, w: int) -> np.ndarray:
        start, F = int(self.plan.starts[w]), self.plan.length
        idx, weight = self.idx[start : start + F], self.w[start : start + F]
        first = int(idx[0])
        window = resample_keypoints_at(self.frames[first : int(idx[-1]) + 2], idx - first, weight)  # (F', C, P, 17, 3)
        return np.moveaxis(_pad(window, F), 0, 2)


class WindowView:
    """``cut(values, plan, axis)[w]`` cut only when window ``w`` is asked for: a long track is not copied per window."""

    def __init__(self, values: np.ndarray, plan: WindowPlan, axis: int) -> None:
        self.values, self.plan, self.axis = values, plan, axis

    def __len__(self) -> int:
        return self.plan.count

    def __getitem__(self, w: int) -> np.ndarray:
        start, F = int(self.plan.starts[w]), self.plan.length
        return np.moveaxis(_pad(np.moveaxis(self.values, self.axis, 0)[start : start + F], F), 0, self.axis)


def _pad(frames: np.ndarray, length: int) -> np.ndarray:
    """``frames`` (t, ...) padded with NaN to ``length`` frames, as :func:`lifting.windows.cut` pads the last window."""
    if len(frames) >= length:
        return frames
    return np.concatenate([frames, np.full((length - len(frames), *frames.shape[1:]), np.nan, frames.dtype)])


class StreamingStitch:
    """:func:`lifting.windows.stitch` then :func:`lifting.timebase.interpolate` onto the input's frame times, streamed.

    Windows are added in order, each a tuple of arrays ``(F, ...)`` (frames first). After
    window w, every prior frame before window w+1 starts is final: those frames are
    resampled to the frame times they cover and handed out. The numbers are those of
    the whole-array path (same float64 sums in the same order, same interpolation).
    """

    def __init__(self, plan: WindowPlan, clock: np.ndarray, frame_times: np.ndarray) -> None:
        self.plan, self.clock, self.frame_times = plan, clock, frame_times
        self.weights = blend_weights(plan)
        self.single = len(clock) == 1
        self.idx, self.w = (None, None) if self.single else interpolation_weights(clock, frame_times)
        self.base = 0  # prior frame of self.sums[0]
        self.sums: list[np.ndarray] | None = None  # per field: float64 (frames, ...) from self.base on
        self.emitted = 0  # input frames handed out so far

    def add(self, w: int, window: tuple[np.ndarray, ...]) -> Iterator[tuple[int, tuple[np.ndarray, ...]]]:
        """Add window ``w`` (fields ``(F, ...)``); yield ``(first input frame, fields (t, ...) float32)`` now final."""
        start, F = int(self.plan.starts[w]), self.plan.length
        weight = self.weights[w]
        if self.sums is None:
            self.sums = [np.zeros((0, *v.shape[1:]), dtype=np.float64) for v in window]
        grow = start + F - (self.base + len(self.sums[0]))
        if grow > 0:
            self.sums = [np.concatenate([s, np.zeros((grow, *s.shape[1:]))]) for s in self.sums]
        for s, value in zip(self.sums, window):
            s[start - self.base : start - self.base + F] += weight.reshape((F,) + (1,) * (value.ndim - 1)) * value
        last = w == self.plan.count - 1
        final = self.plan.total if last else int(self.plan.starts[w + 1])  # prior frames < final are done
        chunk = self._resample(final, last)
        if chunk is not None:
            yield chunk

    def _resample(self, final: int, last: bool) -> tuple[int, tuple[np.ndarray, ...]] | None:
        """Input frames whose two neighbouring prior frames are below ``final`` (all that are left if ``last``)."""
        first, T = self.emitted, len(self.frame_times)
        if self.single:
            stop = T if last else first
        else:
            stop = T if last else first + int(np.searchsorted(self.idx[first:] + 1, final, side="left"))
        if stop <= first:
            return None
        if self.single:
            fields = tuple(np.repeat(s[:1], stop - first, axis=0) for s in self.sums)
        else:
            idx = self.idx[first:stop] - self.base
            fields = tuple(blend_samples(s, idx, self.w[first:stop]) for s in self.sums)
        self.emitted = stop
        if stop < T and not self.single:
            drop = int(self.idx[stop]) - self.base  # prior frames no later input frame needs
            self.sums = [s[drop:] for s in self.sums]
            self.base += drop
        return first, tuple(f.astype(np.float32) for f in fields)


class _WindowRunner:
    """Samples one window of all persons at a time (persons and hypotheses in one batch)."""

    def __init__(self, prior, cameras, per_window, roots, config, settings, plan: WindowPlan, progress) -> None:
        self.prior, self.cameras, self.per_window, self.roots = prior, cameras, per_window, roots
        self.config, self.settings, self.plan, self.progress = config, settings, plan, progress

    def run(self, w: int, anchor: tuple[np.ndarray, np.ndarray] | None) -> SampleResult:
        """Hypotheses of window ``w`` (persons as the batch); ``anchor`` = joints (P, N, F, 17, 3), mask (F,)."""
        kp = self.per_window[w]  # (C, P, F, 17, 3)
        P, F = kp.shape[1:3]
        obs, rays = cameras_and_rays(self.cameras, kp[..., :2], kp[..., 2], device=self.prior.device)
        dtype, device = obs.keypoints.dtype, obs.keypoints.device
        root = torch.as_tensor(self.roots[w], dtype=dtype, device=device) if self.roots is not None else None
        held = None
        if anchor is not None:
            mask = torch.as_tensor(np.repeat(anchor[1][None], P, axis=0), dtype=dtype, device=device)
            held = Anchor(torch.as_tensor(anchor[0], dtype=dtype, device=device), mask, self.settings.anchor_weight)
        result = sample(self.prior, obs, None if root is not None else rays, self.config, F, root, held)
        if self.progress is not None:
            self.progress(w + 1, self.plan.count)
        return result
