"""BVH export: our 17 joints as a BVH hierarchy, rotations fitted to positions by inverse kinematics.

Conventions of the file: Y up, centimetres, a world point (x, y, z) of ours
(Z up, metres) is written as 100 * (x, z, -y), so Blender's default BVH import
(forward -Z, up Y) puts it back in our world frame. The rest pose stands
upright facing +Z (our -y) with the arms out sideways (T-pose); its bone
lengths are the median bone lengths of the motion. Every joint has
``Zrotation Xrotation Yrotation`` channels (local rotation ``Rz @ Rx @ Ry``),
the root also ``Xposition Yposition Zposition`` first.

Rotations are fitted by :mod:`exporters.ik`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from platypose.exporters.frames import Lead, frame_chunks
from platypose.exporters.ik import CHILDREN, euler_to_matrix, fit_rotations, local_euler
from platypose.lifting.atomic import atomic_open
from platypose.lifting.motion_io.kinematics import forward_kinematics
from platypose.lifting.skeleton import BONES, JOINT_NAMES, NUM_JOINTS, PARENTS, bone_lengths

CM_PER_M = 100.0
DECIMALS = 6

# Rest direction of each joint's offset from its parent, BVH axes (x left, y up, z forward).
_LEFT, _RIGHT, _UP, _DOWN, _FORWARD = (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1)
REST_DIRECTIONS = np.array(
    [
        (0, 0, 0),
        _RIGHT,
        _DOWN,
        _DOWN,
        _LEFT,
        _DOWN,
        _DOWN,
        _UP,
        _UP,
        _UP,
        _UP,
        _LEFT,
        _LEFT,
        _LEFT,
        _RIGHT,
        _RIGHT,
        _RIGHT,
    ],
    dtype=np.float64,
)

# End sites of the leaf joints: direction and length as a fraction of the leaf's own bone.
END_SITES: dict[int, tuple[tuple[int, int, int], float]] = {
    JOINT_NAMES.index("right_ankle"): (_FORWARD, 0.35),
    JOINT_NAMES.index("left_ankle"): (_FORWARD, 0.35),
    JOINT_NAMES.index("head"): (_UP, 0.8),
    JOINT_NAMES.index("left_wrist"): (_LEFT, 0.75),
    JOINT_NAMES.index("right_wrist"): (_RIGHT, 0.75),
}


@dataclass(frozen=True)
class BvhFit:
    """Distance between the BVH's joints (after forward kinematics) and the fitted positions, metres."""

    mean_m: float
    max_m: float

    def as_dict(self) -> dict[str, float]:
        """JSON-ready form for ``meta``."""
        return {"mean_m": self.mean_m, "max_m": self.max_m}


def to_bvh_axes(points: np.ndarray) -> np.ndarray:
    """Our Z-up metres ``(..., 3)`` -> BVH Y-up centimetres ``(..., 3)``: (x, y, z) -> 100 (x, z, -y)."""
    x, y, z = np.moveaxis(np.asarray(points, dtype=np.float64), -1, 0)
    return CM_PER_M * np.stack([x, z, -y], axis=-1)


def from_bvh_axes(points: np.ndarray) -> np.ndarray:
    """BVH Y-up centimetres ``(..., 3)`` -> our Z-up metres ``(..., 3)``."""
    x, y, z = np.moveaxis(np.asarray(points, dtype=np.float64), -1, 0)
    return np.stack([x, -z, y], axis=-1) / CM_PER_M


def rest_offsets(lengths: np.ndarray) -> np.ndarray:
    """Rest offsets (17, 3) in BVH centimetres from the median of per-frame bone lengths (T, 16) metres."""
    median = np.nanmedian(lengths, axis=0) * CM_PER_M
    offsets = np.zeros((NUM_JOINTS, 3))
    for b, (child, _) in enumerate(BONES):
        offsets[child] = REST_DIRECTIONS[child] * median[b]
    return offsets


def end_site_offsets(offsets: np.ndarray) -> dict[int, np.ndarray]:
    """End-site offset (3,) of each leaf joint, scaled by that joint's bone length."""
    return {
        j: np.asarray(direction, dtype=np.float64) * fraction * np.linalg.norm(offsets[j])
        for j, (direction, fraction) in END_SITES.items()
    }


def nearest_present(present: np.ndarray) -> np.ndarray:
    """For each frame of ``present`` (T,) bool, the nearest present frame (the earlier one on ties), (T,)."""
    idx = np.flatnonzero(present)
    frames = np.arange(len(present))
    after = np.clip(np.searchsorted(idx, frames), 0, len(idx) - 1)
    before = np.clip(after - 1, 0, len(idx) - 1)
    return np.where(np.abs(idx[before] - frames) <= np.abs(idx[after] - frames), idx[before], idx[after])


def _hierarchy(offsets: np.ndarray) -> list[str]:
    """The HIERARCHY section lines."""
    ends = end_site_offsets(offsets)
    lines = ["HIERARCHY"]

    def emit(j: int, depth: int) -> None:
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if PARENTS[j] < 0 else 'JOINT'} {JOINT_NAMES[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {' '.join(f'{v:.{DECIMALS}f}' for v in offsets[j])}")
        position = "Xposition Yposition Zposition " if PARENTS[j] < 0 else ""
        lines.append(f"{pad}  CHANNELS {6 if PARENTS[j] < 0 else 3} {position}Zrotation Xrotation Yrotation")
        for c in CHILDREN[j]:
            emit(c, depth + 1)
        if j in ends:
            lines.extend([f"{pad}  End Site", f"{pad}  {{"])
            lines.append(f"{pad}    OFFSET {' '.join(f'{v:.{DECIMALS}f}' for v in ends[j])}")
            lines.append(f"{pad}  }}")
        lines.append(f"{pad}}}")

    emit(0, 0)
    return lines


def motion_channels(joints: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Channel values (T, 54), rounded as written, for world joints (T, 17, 3) metres and rest ``offsets`` (17, 3)."""
    positions = to_bvh_axes(joints)
    euler = local_euler(fit_rotations(positions, offsets))
    values = np.concatenate([positions[:, 0], euler.reshape(len(joints), -1)], axis=1)
    return np.round(values, DECIMALS)


def channels_to_positions(values: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """World joints (T, 17, 3) metres from channel values (T, 54) and rest offsets (17, 3)."""
    rotations = euler_to_matrix(values[:, 3:].reshape(len(values), NUM_JOINTS, 3))
    placed = np.broadcast_to(offsets, (len(values), NUM_JOINTS, 3)).copy()
    placed[:, 0] += values[:, :3]  # the root's offset is its position
    return from_bvh_axes(forward_kinematics(PARENTS, placed, rotations))


def write_bvh(joints: np.ndarray | Lead, fps: float, path: Path | str) -> BvhFit:
    """Fit and write world joints (T, 17, 3) metres at ``fps`` to ``path`` atomically; return the fit error.

    Absent (NaN) frames hold the nearest present pose; the fit error is measured on present frames.
    ``joints`` is read a chunk of frames at a time (it may be a view of a file, see :mod:`exporters.frames`).
    """
    T = len(joints)
    present = np.concatenate([np.isfinite(joints[t]).all(axis=(1, 2)) for t in frame_chunks(T)])
    if not present.any():
        raise ValueError(f"{path}: no frame to write, the person is absent throughout")
    pick = nearest_present(present)  # absent frames hold the nearest present pose
    lengths = np.concatenate([bone_lengths(np.asarray(joints[t], np.float64))[present[t]] for t in frame_chunks(T)])
    offsets = np.round(rest_offsets(lengths[(np.cumsum(present) - 1)[pick]]), DECIMALS)
    header = _hierarchy(offsets) + ["MOTION", f"Frames: {T}", f"Frame Time: {1.0 / fps:.8f}"]
    total, count, largest = 0.0, 0, 0.0
    with atomic_open(path, "w", encoding="ascii", newline="\n") as f:
        f.write("\n".join(header) + "\n")
        for t in frame_chunks(T):
            filled = np.asarray(joints[pick[t]], dtype=np.float64)
            values = motion_channels(filled, offsets)
            np.savetxt(f, values, fmt=f"%.{DECIMALS}f", delimiter=" ")
            on = present[t]
            error = np.linalg.norm(channels_to_positions(values, offsets)[on] - filled[on], axis=-1)
            total, count, largest = total + error.sum(), count + error.size, max(largest, error.max(initial=0.0))
    return BvhFit(mean_m=float(total / count), max_m=float(largest))
