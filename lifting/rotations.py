"""Rotations shared by the calibration readers, the BVH inverse kinematics and the rigid lift (scipy's ``Rotation`` underneath)."""

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


def kabsch(rest: np.ndarray, seen: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Rotations (..., 3, 3) minimising ``sum_k w_k |R rest_k - seen_k|^2``; rest (K, 3) or (..., K, 3), seen
    (..., K, 3), weights (K,)."""
    h = np.einsum("k,...ki,...kj->...ij", weights, rest, seen)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.swapaxes(vt, -1, -2) @ np.swapaxes(u, -1, -2)))
    fix = np.broadcast_to(np.eye(3), h.shape).copy()
    fix[..., 2, 2] = np.where(d == 0, 1.0, d)
    return np.swapaxes(vt, -1, -2) @ fix @ np.swapaxes(u, -1, -2)


def unit(v: np.ndarray) -> np.ndarray:
    """Vectors ``(..., 3)`` scaled to length 1 (a zero vector stays zero)."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def two_vector_frame(primary: np.ndarray, secondary: np.ndarray) -> np.ndarray:
    """Orthonormal frames (..., 3, 3), columns: ``primary`` direction, ``secondary`` made orthogonal, their cross."""
    e1 = primary / np.maximum(np.linalg.norm(primary, axis=-1, keepdims=True), 1e-12)
    e2 = secondary - np.sum(secondary * e1, axis=-1, keepdims=True) * e1
    e2 = e2 / np.maximum(np.linalg.norm(e2, axis=-1, keepdims=True), 1e-12)
    return np.stack([e1, e2, np.cross(e1, e2)], axis=-1)


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices (..., 3, 3) of vectors (..., 3): ``skew(a) @ b == a x b``."""
    x, y, z = np.moveaxis(v, -1, 0)
    zero = np.zeros_like(x)
    return np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)


def rotvec_matrices(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3) (axis times angle, radians; Rodrigues' formula).

    Plain numpy, so an interrupt (Ctrl-C, a cancelled task) lands between calls, never inside compiled code that
    would drop it.
    """
    angle = np.linalg.norm(rotvec, axis=-1)[..., None, None]
    k = skew(rotvec / np.maximum(angle[..., 0], 1e-300))
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)
