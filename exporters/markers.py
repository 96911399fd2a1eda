"""Marker trajectories for biomechanics tools: Pose2Sim marker names, OpenSim axes, gaps filled and listed.

OpenSim's inverse kinematics stops on NaN, so the TRC and C3D files hold every
frame: a person's absent frames are filled by linear interpolation between
the nearest present frames (held at the ends), and the filled frames are
listed (:class:`Gap`) in a sidecar JSON and the log.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from platypose.exporters.frames import Lead, frame_chunks
from platypose.lifting.atomic import write_text_atomic

# Pose2Sim's names of the Human3.6M joints, in our joint order.
MARKER_NAMES: tuple[str, ...] = (
    "Hip",
    "RHip",
    "RKnee",
    "RAnkle",
    "LHip",
    "LKnee",
    "LAnkle",
    "Spine",
    "Thorax",
    "Neck",
    "Head",
    "LShoulder",
    "LElbow",
    "LWrist",
    "RShoulder",
    "RElbow",
    "RWrist",
)


@dataclass(frozen=True)
class Gap:
    """Frames ``first .. last`` (inclusive, output frame indices) where the person is absent and values are filled."""

    first: int
    last: int
    start_s: float
    end_s: float
    how: str  # "interpolated" between present frames, or "held" at the start or end of the clip

    def as_dict(self) -> dict:
        """JSON-ready form."""
        return {"first_frame": self.first, "last_frame": self.last, "start_s": self.start_s, "end_s": self.end_s}


def to_opensim_axes(points: np.ndarray) -> np.ndarray:
    """Our Z-up points (..., 3) -> OpenSim's Y-up axes as Pose2Sim writes them: (x, y, z) -> (y, z, x)."""
    return np.asarray(points, dtype=np.float64)[..., [1, 2, 0]]


def read_frames(joints: np.ndarray | Lead) -> np.ndarray:
    """All frames of ``joints`` (T, 17, 3) as float64, read a chunk at a time."""
    return np.concatenate([np.asarray(joints[t], dtype=np.float64) for t in frame_chunks(len(joints))])


def fill_gaps(joints: np.ndarray, frame_times: np.ndarray) -> tuple[np.ndarray, list[Gap]]:
    """Joints (T, 17, 3) with absent (NaN) frames filled, and the gaps that were filled.

    Interior gaps are interpolated linearly in time between the present frames on either side;
    gaps at the start or end hold the first or last present frame. Raises ValueError when no
    frame is present.
    """
    present = np.isfinite(joints).all(axis=(1, 2))
    if not present.any():
        raise ValueError("the person is absent throughout")
    on = np.flatnonzero(present)
    flat = joints[on].reshape(len(on), -1)
    filled = np.stack([np.interp(frame_times, frame_times[on], flat[:, k]) for k in range(flat.shape[1])], axis=1)
    filled = filled.reshape(joints.shape)
    gaps = []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], (~present).astype(np.int8), [0]])))
    for first, stop in zip(edges[::2], edges[1::2]):
        last = stop - 1
        how = "held" if first == 0 or stop == len(present) else "interpolated"
        gaps.append(Gap(int(first), int(last), float(frame_times[first]), float(frame_times[last]), how))
    return filled, gaps


def gaps_sidecar(path: Path, gaps_by_person: dict[str, list[Gap]]) -> Path:
    """Write ``{"p<id>": [{"first_frame", "last_frame", "start_s", "end_s", "how"}, ...]}`` to ``path`` atomically."""
    body = {k: [{**g.as_dict(), "how": g.how} for g in v] for k, v in gaps_by_person.items()}
    return write_text_atomic(path, json.dumps({"filled_gaps": body}, indent=2) + "\n")


def describe_gaps(gaps: list[Gap]) -> str:
    """A short line such as ``2 gaps, 37 frames filled (frames 0-9 held, 50-76 interpolated)``."""
    if not gaps:
        return "no gap"
    frames = sum(g.last - g.first + 1 for g in gaps)
    parts = ", ".join(f"{g.first}-{g.last} {g.how}" for g in gaps[:5]) + (", ..." if len(gaps) > 5 else "")
    return f"{len(gaps)} gap(s), {frames} frame(s) filled (frames {parts})"
