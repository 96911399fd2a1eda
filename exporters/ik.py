"""Inverse kinematics of our 17-joint tree with fixed bone offsets (pure array maths).

IK: a joint with several children (pelvis, thorax) gets the two-vector frame of
its left-right axis (hips, shoulders: kept exactly) and its midline bone
(spine, neck: kept in the plane it makes with that axis); a joint with one
child gets the smallest rotation, relative to its parent, that aims its bone at
the child from where the fitted chain has put it; leaves (wrists, ankles,
head) keep their parent's orientation. Local rotations are ZXY Euler angles
(``Rz @ Rx @ Ry``), as in BVH's ``Zrotation Xrotation Yrotation`` channels. Forward
kinematics is the importers' (:func:`platypose.lifting.motion_io.kinematics.forward_kinematics`).
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from platypose.lifting.skeleton import JOINT_NAMES, NUM_JOINTS, PARENTS

EULER_ORDER = "ZXY"  # intrinsic: R = Rz @ Rx @ Ry

CHILDREN: tuple[tuple[int, ...], ...] = tuple(
    tuple(c for c in range(NUM_JOINTS) if PARENTS[c] == j) for j in range(NUM_JOINTS)
)

# Joints with several children: (left child, right child, midline child). Their rotation is the
# two-vector frame of the left-right axis (kept exactly) and the midline bone (kept in its plane).
LATERAL_CHILDREN: dict[int, tuple[int, int, int]] = {
    JOINT_NAMES.index("pelvis"): tuple(JOINT_NAMES.index(n) for n in ("left_hip", "right_hip", "spine")),
    JOINT_NAMES.index("thorax"): tuple(JOINT_NAMES.index(n) for n in ("left_shoulder", "right_shoulder", "neck")),
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
    flat = Rotation.from_euler(EULER_ORDER, np.reshape(euler, (-1, 3)), degrees=True).as_matrix()
    return flat.reshape(*np.shape(euler)[:-1], 3, 3)
