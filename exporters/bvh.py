"""BVH export: our 17 joints as a BVH hierarchy on a rigid skeleton, rotations fitted to positions.

Conventions of the file: Y up, centimetres, a world point (x, y, z) of ours
(Z up, metres) is written as 100 * (x, z, -y), so Blender's default BVH import
(forward -Z, up Y) puts it back in our world frame. The rest pose stands
upright facing +Z (our -y) with the arms out sideways (T-pose); its bone
lengths and the shape of pelvis and thorax are fitted once over the motion
(:func:`exporters.ik.rest_offsets`). The root has ``Xposition Yposition
Zposition`` then its rotation channels; every joint's rotation channels are in
its own Euler order (:data:`exporters.euler.EULER_ORDERS`), continuous in time.

Rotations are fitted by :mod:`exporters.ik`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from platypose.exporters.euler import EULER_ORDERS, continuous_euler, euler_to_matrix, local_euler
from platypose.exporters.frames import Lead, frame_chunks
from platypose.exporters.gaps import fill_frames, fill_plan
from platypose.exporters.ik import (
    CHILDREN,
    body_directions,
    fit_rotations,
    joint_steps,
    placed_offsets,
    refine_rotations,
    rest_offsets,
)
from platypose.exporters.presence import present_frames
from platypose.exporters.twist import limit_twists
from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.motion_io.kinematics import forward_kinematics
from platypose.lifting.skeleton import BONES, JOINT_NAMES, NUM_JOINTS, PARENTS, bone_lengths

CM_PER_M = 100.0
DECIMALS = 6
# Largest roll of a single-child bone about itself between two frames, degrees (:mod:`exporters.twist`).
MAX_TWIST_STEP = 10.0
# A frame step where no bone of the positions turns further than this is "calm" (BvhFit.calm_step_deg).
CALM_TURN_DEG = 30.0

_LEFT, _RIGHT, _UP, _FORWARD = (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, 0, 1)
# End sites of the leaf joints: direction and length as a fraction of the leaf's own bone.
END_SITES: dict[int, tuple[tuple[int, int, int], float]] = {
    JOINT_NAMES.index("right_ankle"): (_FORWARD, 0.35),
    JOINT_NAMES.index("left_ankle"): (_FORWARD, 0.35),
    JOINT_NAMES.index("head"): (_UP, 0.8),
    JOINT_NAMES.index("left_wrist"): (_LEFT, 0.75),
    JOINT_NAMES.index("right_wrist"): (_RIGHT, 0.75),
}
_NECK, _HEAD = JOINT_NAMES.index("neck"), JOINT_NAMES.index("head")


@dataclass(frozen=True)
class BvhFit:
    """How faithful a written BVH is, measured on present frames by forward kinematics of the written numbers.

    ``mean_m``, ``max_m``: distance of the file's joints to the fitted positions (metres);
    ``head_deg``: largest angle between the file's neck-to-head bone and the positions' one;
    ``step_deg``: largest frame-to-frame change of any joint's local rotation; ``calm_step_deg``: the same
    between present frames where no bone of the positions turns over :data:`CALM_TURN_DEG` (the
    motion's own flips excluded);
    ``stretch_m``: largest difference between a bone's length in a frame of the positions and
    its length in the file (the motion's own non-rigidity, which no rigid skeleton can follow).
    """

    mean_m: float
    max_m: float
    head_deg: float = 0.0
    step_deg: float = 0.0
    calm_step_deg: float = 0.0
    stretch_m: float = 0.0

    def as_dict(self) -> dict[str, float]:
        """JSON-ready form for ``meta``."""
        return {
            "mean_m": self.mean_m,
            "max_m": self.max_m,
            "head_deg": self.head_deg,
            "step_deg": self.step_deg,
            "calm_step_deg": self.calm_step_deg,
            "stretch_m": self.stretch_m,
        }


def to_bvh_axes(points: np.ndarray) -> np.ndarray:
    """Our Z-up metres ``(..., 3)`` -> BVH Y-up centimetres ``(..., 3)``: (x, y, z) -> 100 (x, z, -y)."""
    x, y, z = np.moveaxis(np.asarray(points, dtype=np.float64), -1, 0)
    return CM_PER_M * np.stack([x, z, -y], axis=-1)


def from_bvh_axes(points: np.ndarray) -> np.ndarray:
    """BVH Y-up centimetres ``(..., 3)`` -> our Z-up metres ``(..., 3)``."""
    x, y, z = np.moveaxis(np.asarray(points, dtype=np.float64), -1, 0)
    return np.stack([x, -z, y], axis=-1) / CM_PER_M


def end_site_offsets(offsets: np.ndarray) -> dict[int, np.ndarray]:
    """End-site offset (3,) of each leaf joint, scaled by that joint's bone length."""
    return {
        j: np.asarray(direction, dtype=np.float64) * fraction * np.linalg.norm(offsets[j])
        for j, (direction, fraction) in END_SITES.items()
    }


def _channel_names(j: int) -> str:
    """The CHANNELS line's names of joint ``j``: positions for the root, then rotations in its Euler order."""
    rotations = " ".join(f"{axis}rotation" for axis in EULER_ORDERS[j])
    return f"3 {rotations}" if PARENTS[j] >= 0 else f"6 Xposition Yposition Zposition {rotations}"


def _hierarchy(offsets: np.ndarray) -> list[str]:
    """The HIERARCHY section lines."""
    ends = end_site_offsets(offsets)
    lines = ["HIERARCHY"]

    def emit(j: int, depth: int) -> None:
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if PARENTS[j] < 0 else 'JOINT'} {JOINT_NAMES[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {' '.join(f'{v:.{DECIMALS}f}' for v in offsets[j])}")
        lines.append(f"{pad}  CHANNELS {_channel_names(j)}")
        for c in CHILDREN[j]:
            emit(c, depth + 1)
        if j in ends:
            lines.extend([f"{pad}  End Site", f"{pad}  {{"])
            lines.append(f"{pad}    OFFSET {' '.join(f'{v:.{DECIMALS}f}' for v in ends[j])}")
            lines.append(f"{pad}  }}")
        lines.append(f"{pad}}}")

    emit(0, 0)
    return lines


def fit_skeleton(joints: np.ndarray | Lead, present: np.ndarray) -> np.ndarray:
    """Rigid rest offsets (17, 3) BVH centimetres fitted over the present frames of world joints (T, 17, 3)."""
    lengths, directions = [], []
    for t in frame_chunks(len(joints)):
        on = present[t]
        positions = to_bvh_axes(np.asarray(joints[t], np.float64)[on])
        lengths.append(bone_lengths(positions))
        directions.append(body_directions(positions))
    return np.round(rest_offsets(np.concatenate(lengths), np.concatenate(directions)), DECIMALS)


@dataclass(frozen=True)
class Carry:
    """What the next chunk of frames continues from: the last frame's channel values (54,), the
    limbs' hinge state (4, 2, 3) after it (:func:`exporters.ik.fit_rotations`) and its local
    rotations (17, 3, 3) (:func:`exporters.twist.limit_twists`)."""

    values: np.ndarray
    hinges: np.ndarray
    local: np.ndarray


def motion_channels(
    joints: np.ndarray, offsets: np.ndarray, before: Carry | None = None
) -> tuple[np.ndarray, np.ndarray, Carry]:
    """Channel values (T, 54) rounded as written, the fitted global rotations (T, 17, 3, 3) and what the
    next chunk continues from.

    ``joints`` are world joints (T, 17, 3) metres; ``before`` what the chunk before left (its last
    frame's channel values, which the Euler angles continue from, and its limbs' hinge axes).
    """
    positions = to_bvh_axes(joints)
    first, hinges = fit_rotations(positions, offsets, None if before is None else before.hinges)
    rot, root = refine_rotations(first, positions, offsets)
    rot, local = limit_twists(rot, offsets, MAX_TWIST_STEP, None if before is None else before.local)
    euler = continuous_euler(local_euler(rot), None if before is None else before.values[3:].reshape(NUM_JOINTS, 3))
    values = np.round(np.concatenate([root, euler.reshape(len(joints), -1)], axis=1), DECIMALS)
    return values, rot, Carry(values[-1], hinges, local)


def channels_to_positions(values: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """World joints (T, 17, 3) metres from channel values (T, 54) and rest offsets (17, 3)."""
    rotations = euler_to_matrix(values[:, 3:].reshape(len(values), NUM_JOINTS, 3))
    return from_bvh_axes(forward_kinematics(PARENTS, placed_offsets(offsets, values[:, :3]), rotations))


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles (...) in degrees between vectors ``a`` and ``b`` (..., 3)."""
    cos = np.sum(a * b, -1) / np.maximum(np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1), 1e-12)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _bone_turns(joints: np.ndarray) -> np.ndarray:
    """Largest angle (T - 1,) in degrees by which any bone of joints (T, 17, 3) turns between consecutive frames."""
    bones = np.stack([joints[:, child] - joints[:, parent] for child, parent in BONES], axis=1)
    return _angle_deg(bones[1:], bones[:-1]).max(axis=1, initial=0.0)


def _head_bone(joints: np.ndarray) -> np.ndarray:
    """Neck-to-head vectors (T, 3) of joints (T, 17, 3)."""
    return joints[:, _HEAD] - joints[:, _NECK]


def write_bvh(joints: np.ndarray | Lead, fps: float, path: Path | str, frame_times: np.ndarray | None = None) -> BvhFit:
    """Fit and write world joints (T, 17, 3) metres at ``fps`` to ``path`` atomically; return the fit error.

    Absent (NaN) frames, and frames collapsed to a point, are filled by the gap rule of :mod:`exporters.gaps` (interpolated in ``frame_times``,
    default ``frame / fps``, held at the ends); the fit error is measured on present frames. ``joints`` is
    read a chunk of frames at a time (it may be a view of a file, see :mod:`exporters.frames`).
    """
    T = len(joints)
    present = np.concatenate([present_frames(joints[t]) for t in frame_chunks(T)])
    if not present.any():
        raise ValueError(f"{path}: no frame to write, the person is absent throughout")
    plan = fill_plan(present, np.arange(T) / fps if frame_times is None else frame_times)
    offsets = fit_skeleton(joints, present)
    rigid = np.array([np.linalg.norm(offsets[child]) for child, _ in BONES]) / CM_PER_M
    header = _hierarchy(offsets) + ["MOTION", f"Frames: {T}", f"Frame Time: {1.0 / fps:.12g}"]
    total, count, largest, head, step, calm, stretch = 0.0, 0, 0.0, 0.0, 0.0, 0.0, 0.0
    carry, last = None, None  # the chunk before's last rotations (1, 17, 3, 3), positions and presence
    with atomic_open(path, "w", encoding="ascii", newline="\n") as f:
        f.write("\n".join(header) + "\n")
        for t in frame_chunks(T):
            filled = np.asarray(fill_frames(joints, plan, t), dtype=np.float64)
            values, rot, carry = motion_channels(filled, offsets, carry)
            np.savetxt(f, values, fmt=f"%.{DECIMALS}f", delimiter=" ")
            on = present[t]
            back = channels_to_positions(values, offsets)
            error = np.linalg.norm(back[on] - filled[on], axis=-1)
            total, count, largest = total + error.sum(), count + error.size, max(largest, error.max(initial=0.0))
            head = max(head, _angle_deg(_head_bone(back), _head_bone(filled))[on].max(initial=0.0))
            rots, seen, ons = (
                (rot, filled, on)
                if last is None
                else (np.concatenate([last[0], rot]), np.concatenate([last[1], filled]), np.concatenate([last[2], on]))
            )
            steps = joint_steps(rots).max(axis=1, initial=0.0)
            quiet = ons[1:] & ons[:-1] & (_bone_turns(seen) <= CALM_TURN_DEG)
            step, calm = max(step, float(steps.max(initial=0.0))), max(calm, float(steps[quiet].max(initial=0.0)))
            stretch = max(stretch, float(np.abs(bone_lengths(filled[on]) - rigid).max(initial=0.0)))
            last = (rot[-1:], filled[-1:], on[-1:])
    return BvhFit(
        mean_m=float(total / count),
        max_m=float(largest),
        head_deg=float(head),
        step_deg=step,
        calm_step_deg=calm,
        stretch_m=stretch,
    )
