"""Euler angles of the BVH channels: one intrinsic order per joint, continuous in time.

Each joint's order (:data:`EULER_ORDERS`) puts gimbal lock on a rotation the joint does not make (a
bone's twist, or the root pitching to horizontal); :func:`continuous_euler` picks, frame after frame,
the equivalent angles nearest the previous frame's, so channels never wrap by 360 degrees.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from platypose.exporters.ik import local_rotations

# Intrinsic Euler order of each joint's local rotation (the BVH channel order). The middle axis is
# the one where gimbal lock sits at 90 degrees: the bone's own axis (twist) for limbs and trunk,
# the pitch for the root (whose heading turns freely).
_LEG, _ARM = "ZYX", "ZXY"
EULER_ORDERS: tuple[str, ...] = ("YXZ", _LEG, _LEG, _LEG, _LEG, _LEG, _LEG, _LEG, _LEG, _LEG, _LEG) + (_ARM,) * 6


def local_euler(global_rot: np.ndarray) -> np.ndarray:
    """Local Euler angles (T, 17, 3) in degrees, each joint in its :data:`EULER_ORDERS` order."""
    local = local_rotations(global_rot)
    out = np.zeros(global_rot.shape[:2] + (3,))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # gimbal lock: angles still reproduce the matrix
        for j, order in enumerate(EULER_ORDERS):
            out[:, j] = Rotation.from_matrix(local[:, j]).as_euler(order, degrees=True)
    return out


def continuous_euler(angles: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """Euler angles (T, J, 3) degrees re-expressed frame by frame as the equivalent angles nearest the previous.

    Each Tait-Bryan rotation has two angle triples, ``(a, b, c)`` and ``(a + 180, 180 - b, c + 180)``,
    and each angle is defined modulo 360: the one closest to the frame before is kept (``previous``
    (J, 3) is the frame before the first, e.g. the last of the previous chunk).
    """
    alt = angles + np.array([180.0, 0.0, 180.0])
    alt[..., 1] = 180.0 - angles[..., 1]
    out = np.empty_like(angles)
    prev = previous
    for t in range(len(angles)):
        if prev is None:
            out[t] = angles[t]
        else:
            a = prev + (angles[t] - prev + 180.0) % 360.0 - 180.0
            b = prev + (alt[t] - prev + 180.0) % 360.0 - 180.0
            keep = np.abs(a - prev).sum(-1) <= np.abs(b - prev).sum(-1)
            out[t] = np.where(keep[:, None], a, b)
        prev = out[t]
    return out


def euler_to_matrix(euler: np.ndarray) -> np.ndarray:
    """Local rotation matrices (T, 17, 3, 3) from Euler degrees (T, 17, 3) in each joint's :data:`EULER_ORDERS`."""
    out = np.zeros(euler.shape[:2] + (3, 3))
    for j, order in enumerate(EULER_ORDERS):
        out[:, j] = Rotation.from_euler(order, euler[:, j], degrees=True).as_matrix()
    return out
