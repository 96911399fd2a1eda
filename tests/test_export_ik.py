"""Kinematics used by the BVH writer, against hand-checkable cases and scipy."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from platypose.exporters.ik import euler_to_matrix, local_euler, rotation_between, two_vector_frame
from platypose.lifting.skeleton import PARENTS


def test_rotation_between_maps_a_onto_b_including_opposite_vectors():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(200, 3))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = rng.normal(size=(200, 3))
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    b[0], b[1] = -a[0], a[1]  # opposite and identical
    R = rotation_between(a, b)
    np.testing.assert_allclose(np.einsum("tij,tj->ti", R, a), b, atol=1e-12)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    np.testing.assert_allclose(R[1], np.eye(3), atol=1e-12)


def test_two_vector_frame_keeps_the_primary_axis():
    frame = two_vector_frame(np.array([2.0, 0.0, 0.0]), np.array([1.0, 3.0, 0.0]))
    np.testing.assert_allclose(frame, np.eye(3), atol=1e-12)


def test_euler_zxy_matches_scipy_and_round_trips():
    angles = np.random.default_rng(1).uniform(-170, 170, size=(50, 17, 3))
    angles[..., 1] = np.clip(angles[..., 1], -80, 80)  # away from gimbal lock, so angles are unique
    matrices = euler_to_matrix(angles)
    expected = Rotation.from_euler("ZXY", angles.reshape(-1, 3), degrees=True).as_matrix().reshape(50, 17, 3, 3)
    np.testing.assert_allclose(matrices, expected, atol=1e-12)
    # global rotations of a tree whose local rotations are ``matrices`` give the same angles back
    glob = np.zeros_like(matrices)
    for j, p in enumerate(PARENTS):
        glob[:, j] = matrices[:, j] if p < 0 else glob[:, p] @ matrices[:, j]
    np.testing.assert_allclose(local_euler(glob), angles, atol=1e-8)
