"""Rotations shared by the calibration readers and the BVH inverse kinematics (scipy's ``Rotation`` underneath)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smallest rotations (..., 3, 3) taking unit vectors ``a`` onto unit vectors ``b`` (..., 3).

    Opposite vectors get a half turn about an axis perpendicular to ``a``.
    """
    a, b = np.broadcast_arrays(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))
    axis = np.cross(a, b)
    sin, cos = np.linalg.norm(axis, axis=-1), np.sum(a * b, axis=-1)
    helper = np.where(np.abs(a[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    axis = np.where((sin < 1e-12)[..., None], np.cross(a, helper), axis)  # (anti)parallel: any perpendicular axis
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    rotvec = axis * np.arctan2(sin, cos)[..., None]
    return Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_matrix().reshape(*a.shape[:-1], 3, 3)
