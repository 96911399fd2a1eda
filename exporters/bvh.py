"""BVH export: our 17 joints as a BVH hierarchy, rotations fitted to positions by inverse kinematics.

Conventions of the file: Y up, centimetres, a world point (x, y, z) of ours
(Z up, metres) is written as 100 * (x, z, -y), so Blender's default BVH import
(forward -Z, up Y) puts it back in our world frame. The rest pose stands
upright facing +Z (our -y) with the arms out sideways (T-pose); its bone
lengths are the median bone lengths of the motion. Every joint has
``Zrotation Xrotation Yrotation`` channels (local rotation ``Rz @ Rx @ Ry``),
the root also ``Xposition Yposition Zposition`` first.

IK: a joint with several children (pelvis, thorax) gets the two-vector frame of
its left-right axis (hips, shoulders: kept exactly) and its midline bone (spine,
neck: kept in the plane it makes with that axis); a joint with
one child gets the smallest rotation, relative to its parent, that points its
bone at the child; wrists, ankles and head keep their parent's orientation.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from exporters.atomic import atomic_path
from lifting.skeleton import BONES, JOINT_NAMES, NUM_JOINTS, PARENTS, bone_lengths

CM_PER_M = 100.0
EULER_ORDER = "ZXY"  # intrinsic: R = Rz @ Rx @ Ry, as BVH channel order Zrotation Xrotation Yrotation
DECIMALS = 6

# Rest direction of each joint's offset from its parent, BVH axes (x left, y up, z forward).
_LEFT, _RIGHT, _UP, _DOWN, _FORWARD = (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1)
REST_DIRECTIONS = np.array(
    [
        (0, 0, 0), _RIGHT, _DOWN, _DOWN, _LEFT, _DOWN, _DOWN, _UP, _UP, _UP, _UP,
        _LEFT, _LEFT, _LEFT, _RIGHT, _RIGHT, _RIGHT,
    ],
    dtype=np.float64,
)  # fmt: skip

# End sites of the leaf joints: direction and length as a fraction of the leaf's own bone.
END_SITES: dict[int, tuple[tuple[int, int, int], float]] = {
    JOINT_NAMES.index("right_ankle"): (_FORWARD, 0.35),
    JOINT_NAMES.index("left_ankle"): (_FORWARD, 0.35),
    JOINT_NAMES.index("head"): (_UP, 0.8),
    JOINT_NAMES.index("left_wrist"): (_LEFT, 0.75),
    JOINT_NAMES.index("right_wrist"): (_RIGHT, 0.75),
}

# Joints with several children: (left child, right child, midline child). Their rotation is the
# two-vector frame of the left-right axis (kept exactly) and the midline bone (kept in its plane).
LATERAL_CHILDREN: dict[int, tuple[int, int, int]] = {
    JOINT_NAMES.index("pelvis"): tuple(JOINT_NAMES.index(n) for n in ("left_hip", "right_hip", "spine")),
    JOINT_NAMES.index("thorax"): tuple(JOINT_NAMES.index(n) for n in ("left_shoulder", "right_shoulder", "neck")),
}

CHILDREN: tuple[tuple[int, ...], ...] = tuple(
    tuple(c for c in range(NUM_JOINTS) if PARENTS[c] == j) for j in range(NUM_JOINTS)
)


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


def rest_offsets(joints: np.ndarray) -> np.ndarray:
    """Rest offsets (17, 3) in BVH centimetres from median bone lengths of ``joints`` (T, 17, 3) metres."""
    lengths = np.nanmedian(bone_lengths(joints), axis=0) * CM_PER_M
    offsets = np.zeros((NUM_JOINTS, 3))
    for b, (child, _) in enumerate(BONES):
        offsets[child] = REST_DIRECTIONS[child] * lengths[b]
    return offsets


def end_site_offsets(offsets: np.ndarray) -> dict[int, np.ndarray]:
    """End-site offset (3,) of each leaf joint, scaled by that joint's bone length."""
    return {
        j: np.asarray(direction, dtype=np.float64) * fraction * np.linalg.norm(offsets[j])
        for j, (direction, fraction) in END_SITES.items()
    }


def _unit(v: np.ndarray) -> np.ndarray:
    """Unit vectors along the last axis."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices (..., 3, 3) of vectors (..., 3)."""
    x, y, z = np.moveaxis(v, -1, 0)
    zero = np.zeros_like(x)
    return np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smallest rotations (..., 3, 3) taking unit vectors ``a`` onto unit vectors ``b`` (..., 3)."""
    cos = np.sum(a * b, axis=-1)
    opposite = cos < -1 + 1e-9
    # Opposite vectors: a half turn about an axis perpendicular to a.
    helper = np.where(np.abs(a[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    axis = np.where(opposite[..., None], _unit(np.cross(a, helper)), np.cross(a, b))
    k = _skew(axis)
    linear = np.where(opposite[..., None, None], 0.0, k)
    scale = np.where(opposite, 2.0, 1.0 / np.maximum(1.0 + cos, 1e-12))[..., None, None]
    return np.eye(3) + linear + scale * (k @ k)


def two_vector_frame(primary: np.ndarray, secondary: np.ndarray) -> np.ndarray:
    """Orthonormal frames (..., 3, 3), columns: ``primary`` direction, ``secondary`` made orthogonal, their cross."""
    e1 = _unit(primary)
    e2 = _unit(secondary - np.sum(secondary * e1, axis=-1, keepdims=True) * e1)
    return np.stack([e1, e2, np.cross(e1, e2)], axis=-1)


def fit_rotations(positions: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Global joint rotations (T, 17, 3, 3) for BVH-axes positions (T, 17, 3) and rest ``offsets`` (17, 3).

    Each joint aims from where the fitted chain has put it (not from its observed
    position), so a bone-length mismatch is not passed on to the joints below.
    """
    T = positions.shape[0]
    rot = np.zeros((T, NUM_JOINTS, 3, 3))
    fitted = np.zeros((T, NUM_JOINTS, 3))
    for j in range(NUM_JOINTS):
        p = PARENTS[j]
        if p < 0:
            parent_rot, fitted[:, j] = np.broadcast_to(np.eye(3), (T, 3, 3)), positions[:, j]
        else:
            parent_rot, fitted[:, j] = rot[:, p], fitted[:, p] + rot[:, p] @ offsets[j]
        kids = CHILDREN[j]
        if not kids:
            rot[:, j] = parent_rot
        elif len(kids) == 1:
            rest = _unit(parent_rot @ offsets[kids[0]])
            seen = _unit(positions[:, kids[0]] - fitted[:, j])
            rot[:, j] = rotation_between(rest, seen) @ parent_rot
        else:
            left, right, mid = LATERAL_CHILDREN[j]
            rest = two_vector_frame(offsets[left] - offsets[right], offsets[mid])
            seen = two_vector_frame(positions[:, left] - positions[:, right], positions[:, mid] - fitted[:, j])
            rot[:, j] = seen @ rest.T
    return rot


def local_euler(global_rot: np.ndarray) -> np.ndarray:
    """Local ZXY Euler angles (T, 17, 3) in degrees, as (z, x, y), from global rotations (T, 17, 3, 3)."""
    parent_rot = np.concatenate(
        [np.broadcast_to(np.eye(3), global_rot[:, :1].shape), global_rot[:, list(PARENTS[1:])]], axis=1
    )
    local = np.swapaxes(parent_rot, -1, -2) @ global_rot
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # gimbal lock: angles still reproduce the matrix
        angles = Rotation.from_matrix(local.reshape(-1, 3, 3)).as_euler(EULER_ORDER, degrees=True)
    return angles.reshape(global_rot.shape[0], NUM_JOINTS, 3)


def euler_to_matrix(euler: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) ``Rz @ Rx @ Ry`` from ZXY Euler degrees (..., 3) given as (z, x, y)."""
    cz, cx, cy = np.moveaxis(np.cos(np.radians(euler)), -1, 0)
    sz, sx, sy = np.moveaxis(np.sin(np.radians(euler)), -1, 0)
    rows = [
        [cz * cy - sz * sx * sy, -sz * cx, cz * sy + sz * sx * cy],
        [sz * cy + cz * sx * sy, cz * cx, sz * sy - cz * sx * cy],
        [-cx * sy, sx, cx * cy],
    ]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def forward_kinematics(euler: np.ndarray, root: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """BVH-axes joint positions (T, 17, 3) from local ZXY Euler degrees (T, 17, 3), root (T, 3), offsets (17, 3)."""
    local = euler_to_matrix(euler)
    rot = np.zeros_like(local)
    pos = np.zeros(euler.shape)
    for j in range(NUM_JOINTS):
        p = PARENTS[j]
        if p < 0:
            rot[:, j], pos[:, j] = local[:, j], root + offsets[j]
        else:
            rot[:, j] = rot[:, p] @ local[:, j]
            pos[:, j] = pos[:, p] + rot[:, p] @ offsets[j]
    return pos


def fill_absent(joints: np.ndarray) -> np.ndarray:
    """Replace NaN frames of ``joints`` (T, 17, 3) by the nearest present frame (earlier one on ties)."""
    present = np.isfinite(joints).all(axis=(1, 2))
    if present.all():
        return joints
    idx = np.flatnonzero(present)
    frames = np.arange(len(joints))
    after = np.clip(np.searchsorted(idx, frames), 0, len(idx) - 1)
    before = np.clip(after - 1, 0, len(idx) - 1)
    pick = np.where(np.abs(idx[before] - frames) <= np.abs(idx[after] - frames), idx[before], idx[after])
    return joints[pick]


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


def motion_channels(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rest offsets (17, 3) and channel values (T, 54) for world joints (T, 17, 3) metres, rounded as written."""
    joints = fill_absent(np.asarray(joints, dtype=np.float64))
    offsets = np.round(rest_offsets(joints), DECIMALS)
    positions = to_bvh_axes(joints)
    euler = local_euler(fit_rotations(positions, offsets))
    values = np.concatenate([positions[:, 0], euler.reshape(len(joints), -1)], axis=1)
    return offsets, np.round(values, DECIMALS)


def channels_to_positions(values: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """World joints (T, 17, 3) metres from channel values (T, 54) and rest offsets (17, 3)."""
    euler = values[:, 3:].reshape(len(values), NUM_JOINTS, 3)
    return from_bvh_axes(forward_kinematics(euler, values[:, :3], offsets))


def write_bvh(joints: np.ndarray, fps: float, path: Path | str) -> BvhFit:
    """Fit and write world joints (T, 17, 3) metres at ``fps`` to ``path`` atomically; return the fit error.

    Absent (NaN) frames hold the nearest present pose; the fit error is measured on present frames.
    """
    joints = np.asarray(joints, dtype=np.float64)
    present = np.isfinite(joints).all(axis=(1, 2))
    if not present.any():
        raise ValueError(f"{path}: no frame to write, the person is absent throughout")
    offsets, values = motion_channels(joints)
    error = np.linalg.norm(channels_to_positions(values, offsets)[present] - joints[present], axis=-1)
    header = _hierarchy(offsets) + ["MOTION", f"Frames: {len(values)}", f"Frame Time: {1.0 / fps:.8f}"]
    with atomic_path(Path(path)) as tmp, open(tmp, "w", encoding="ascii", newline="\n") as f:
        f.write("\n".join(header) + "\n")
        np.savetxt(f, values, fmt=f"%.{DECIMALS}f", delimiter=" ")
    return BvhFit(mean_m=float(error.mean()), max_m=float(error.max()))
