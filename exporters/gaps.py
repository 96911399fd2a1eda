"""The one gap rule of every per-frame file: a person's absent frames filled the same way, and marked.

A person is absent in a frame when no view saw them (the npz holds NaN there, the
source of truth), or when their joints all lie within ``MIN_BODY_EXTENT_M`` of one point (a lift collapsed to a
point has no bones to fit: no rotation, no scale; :func:`platypose.exporters.presence.present_frames`). Every other
file (BVH, TRC, C3D, the CSVs, the joint angles)
holds every frame of the clip for every person it writes, filled by one rule:

- a gap between two present frames is interpolated linearly in time, joint by
  joint, from the last present frame before it to the first after it (a person
  seen again elsewhere glides there; nothing jumps);
- a gap at the start or the end of the clip holds the first or last present frame.

A person unseen for at most ``--max-gap`` seconds between seen frames is present: the lift carried the
motion through (each hypothesis continues its own motion, the prior's spread their uncertainty), and those
frames are written as lifted, but marked as **filled by the prior** (``how`` "prior").

Tables carry a ``filled`` column (1 on filled frames, either way), the C3D a residual of 0, and
``<name>_gaps.json`` lists each person's gaps (:func:`gaps_sidecar`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from platypose.exporters.frames import Lead
from platypose.exporters.result import LiftResult
from platypose.lifting.files.atomic import write_text_atomic


@dataclass(frozen=True)
class Gap:
    """Frames ``first .. last`` (inclusive, output frame indices) where the person is absent and values are filled."""

    first: int
    last: int
    start_s: float
    end_s: float
    how: str  # "interpolated" between present frames, "held" at the start or end of the clip, or "prior" (lifted)

    def as_dict(self) -> dict:
        """JSON-ready form."""
        return {
            "first_frame": self.first,
            "last_frame": self.last,
            "start_s": self.start_s,
            "end_s": self.end_s,
            "how": self.how,
        }


@dataclass(frozen=True)
class FillPlan:
    """How each frame (T,) is made: ``(1 - weight) * value[before] + weight * value[after]``.

    Present frames are their own ``before`` and ``after`` with weight 0 (their values unchanged).
    """

    before: np.ndarray
    after: np.ndarray
    weight: np.ndarray
    present: np.ndarray
    prior: np.ndarray  # (T,) present frames no view saw: lifted through a detection gap, filled by the prior

    @property
    def filled(self) -> np.ndarray:
        """Frames ``(T,)`` not seen: absent (filled by this rule) or filled by the prior."""
        return ~self.present | self.prior


def fill_plan(present: np.ndarray, frame_times: np.ndarray, seen: np.ndarray | None = None) -> FillPlan:
    """The :class:`FillPlan` of presence ``present`` (T,) bool at ``frame_times`` (T,) s, ``seen`` (T,) the frames a
    view saw (default: every present one; :meth:`exporters.result.LiftResult.seen`); ValueError if none is present."""
    present = np.asarray(present, dtype=bool)
    prior = np.zeros_like(present) if seen is None else present & ~np.asarray(seen, dtype=bool)
    if not present.any():
        raise ValueError("the person is absent throughout")
    on = np.flatnonzero(present)
    frames = np.arange(len(present))
    after = on[np.clip(np.searchsorted(on, frames), 0, len(on) - 1)]
    before = on[np.clip(np.searchsorted(on, frames, side="right") - 1, 0, len(on) - 1)]
    before = np.where(frames < on[0], on[0], before)  # held at the start
    after = np.where(frames > on[-1], on[-1], after)  # held at the end
    times = np.asarray(frame_times, dtype=np.float64)
    span = times[after] - times[before]
    weight = np.where(span > 0, (times - times[before]) / np.where(span > 0, span, 1.0), 0.0)
    return FillPlan(before, after, np.clip(weight, 0.0, 1.0), present, prior)


def person_plans(result: LiftResult) -> dict[int, FillPlan]:
    """The :class:`FillPlan` of each person index of ``result`` present in at least one frame, frames no view saw
    marked as filled by the prior."""
    present, seen = result.present(), result.seen()
    return {p: fill_plan(present[p], result.frame_times, seen[p]) for p in range(len(present)) if present[p].any()}


def fill_frames(values: np.ndarray | Lead, plan: FillPlan, frames: slice, axis: int = 0) -> np.ndarray:
    """``values`` (an array or a :class:`exporters.frames.Lead`, frames on ``axis``) of ``frames`` with gaps filled
    by ``plan``, reading only the frames needed. Present frames come back as read, in the values' own dtype."""
    before, after = plan.before[frames], plan.after[frames]
    if axis == 0:
        low, high = np.asarray(values[before]), np.asarray(values[after])
    else:  # frame by frame: numpy would move an index array behind a slice to the front
        index = np.unique(np.concatenate([before, after]))
        block = np.stack([np.asarray(values[(slice(None),) * axis + (int(i),)]) for i in index], axis=axis)
        low = np.take(block, np.searchsorted(index, before), axis=axis)
        high = np.take(block, np.searchsorted(index, after), axis=axis)
    shape = [1] * low.ndim
    shape[axis] = -1
    w = plan.weight[frames].reshape(shape)
    mixed = low.astype(np.float64) + w * (high.astype(np.float64) - low.astype(np.float64))
    return np.where(w > 0, mixed, low).astype(low.dtype)


def find_gaps(plan: FillPlan, frame_times: np.ndarray) -> list[Gap]:
    """The runs of absent frames of ``plan``, each with how it is filled, and the runs filled by the prior; in
    frame order."""
    T = len(plan.present)
    gaps = []
    for run, kind in ((~plan.present, None), (plan.prior, "prior")):
        edges = np.flatnonzero(np.diff(np.concatenate([[0], run.astype(np.int8), [0]])))
        for first, stop in zip(edges[::2], edges[1::2]):
            how = kind or ("held" if first == 0 or stop == T else "interpolated")
            gaps.append(Gap(int(first), int(stop - 1), float(frame_times[first]), float(frame_times[stop - 1]), how))
    return sorted(gaps, key=lambda gap: gap.first)


def gaps_sidecar(path: Path, gaps_by_person: dict[str, list[Gap]]) -> Path:
    """Write ``{"filled_gaps": {"p<id>": [{"first_frame", "last_frame", "start_s", "end_s", "how"}, ...]}}``."""
    body = {k: [g.as_dict() for g in v] for k, v in gaps_by_person.items()}
    return write_text_atomic(path, json.dumps({"filled_gaps": body}, indent=2) + "\n")


def describe_gaps(gaps: list[Gap]) -> str:
    """A short line such as ``2 gaps, 37 frames filled (frames 0-9 held, 50-76 prior)``."""
    if not gaps:
        return "no gap"
    frames = sum(g.last - g.first + 1 for g in gaps)
    parts = ", ".join(f"{g.first}-{g.last} {g.how}" for g in gaps[:5]) + (", ..." if len(gaps) > 5 else "")
    return f"{len(gaps)} gap(s), {frames} frame(s) filled (frames {parts})"
