"""Kinematics used by the BVH writer, against hand-checkable cases and scipy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_export_bvh import _largest_bone_turn

from platypose.exporters import frames
from platypose.exporters.bvh import fit_skeleton, motion_channels, to_bvh_axes, write_bvh
from platypose.exporters.euler import EULER_ORDERS, continuous_euler, euler_to_matrix, local_euler
from platypose.exporters.ik import (
    CHILDREN,
    LIMBS,
    fit_rotations,
    hinge_alignment,
    joint_steps,
    kabsch,
    refine_rotations,
    rotation_between,
    two_vector_frame,
)
from platypose.lifting.skeleton import JOINT_NAMES, PARENTS


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


def test_euler_per_joint_orders_match_scipy_and_round_trip():
    angles = np.random.default_rng(1).uniform(-170, 170, size=(50, 17, 3))
    angles[..., 1] = np.clip(angles[..., 1], -80, 80)  # away from gimbal lock, so angles are unique
    matrices = euler_to_matrix(angles)
    for j, order in enumerate(EULER_ORDERS):
        expected = Rotation.from_euler(order, angles[:, j], degrees=True).as_matrix()
        np.testing.assert_allclose(matrices[:, j], expected, atol=1e-12)
    # global rotations of a tree whose local rotations are ``matrices`` give the same angles back
    glob = np.zeros_like(matrices)
    for j, p in enumerate(PARENTS):
        glob[:, j] = matrices[:, j] if p < 0 else glob[:, p] @ matrices[:, j]
    np.testing.assert_allclose(local_euler(glob), angles, atol=1e-8)


def test_continuous_euler_never_wraps_and_keeps_the_rotation():
    """A joint turning steadily through 720 degrees about each axis in turn: channels follow without jumps."""
    t = np.linspace(0, 720, 400)
    truth = np.stack([t, 0.5 * np.sin(t / 40) * 100, -t], axis=-1)[:, None]  # (T, 1, 3), middle through +-50
    raw = Rotation.from_euler("ZYX", truth[:, 0], degrees=True).as_euler("ZYX", degrees=True)[:, None]
    assert np.abs(np.diff(raw, axis=0)).max() > 300  # what a per-frame decomposition gives
    smooth = continuous_euler(raw)
    assert np.abs(np.diff(smooth, axis=0)).max() < 5
    back = Rotation.from_euler("ZYX", smooth[:, 0], degrees=True).as_matrix()
    np.testing.assert_allclose(back, Rotation.from_euler("ZYX", truth[:, 0], degrees=True).as_matrix(), atol=1e-9)
    # continuing from the last frame of an earlier chunk gives the same as one pass
    np.testing.assert_allclose(continuous_euler(raw[200:], smooth[199]), smooth[200:], atol=1e-9)


def test_kabsch_recovers_a_rotation_and_weights_count():
    rng = np.random.default_rng(3)
    truth = Rotation.random(20, random_state=4).as_matrix()
    rest = rng.normal(size=(4, 3))
    seen = np.einsum("tij,kj->tki", truth, rest)
    np.testing.assert_allclose(kabsch(rest, seen, np.ones(4)), truth, atol=1e-10)
    # a point that disagrees pulls the fit less when it weighs less
    bad = seen.copy()
    bad[:, 3] += 0.5
    heavy = kabsch(rest, bad, np.ones(4))
    light = kabsch(rest, bad, np.array([1.0, 1.0, 1.0, 0.01]))
    angle = lambda a: np.degrees(Rotation.from_matrix(np.swapaxes(a, 1, 2) @ truth).magnitude())  # noqa: E731
    assert angle(light).max() < angle(heavy).max()


def test_refinement_keeps_the_first_fits_twist_of_single_child_bones(real_clips):
    """Refining the rotations of a real, non-rigid walk (1 cm noise) turns each single-child bone's joint by the
    smallest rotation between its first and refined bone directions: the twist about that bone, which moves no
    joint, stays the first fit's (a drifted twist made 100-140 degree pops in one-view BVHs)."""
    walk = next(m for m in real_clips if "walk" in m.name)
    joints = walk.joints[:90] + np.random.default_rng(2).normal(0.0, 0.01, walk.joints[:90].shape)
    positions = to_bvh_axes(joints)
    offsets = fit_skeleton(joints, np.ones(len(joints), bool))
    first, _ = fit_rotations(positions, offsets)
    refined, _ = refine_rotations(first, positions, offsets)
    for j in range(len(PARENTS)):
        if len(CHILDREN[j]) != 1 or j == JOINT_NAMES.index("neck"):  # the neck is aimed at the head last
            continue
        child = offsets[CHILDREN[j][0]]
        swing = rotation_between(
            first[:, j] @ child / np.linalg.norm(child), refined[:, j] @ child / np.linalg.norm(child)
        )
        np.testing.assert_allclose(refined[:, j], swing @ first[:, j], atol=1e-9)


@pytest.fixture(scope="module")
def cam01_median():
    """The median motion of the Pose2Sim balancing take lifted from cam01 alone (100 frames, 60 fps, rigid)."""
    return np.load(Path(__file__).parent / "data" / "lifts" / "pose2sim_cam01_median.npy").astype(np.float64)


def test_one_view_elbow_swing_turns_the_arm_without_a_pop(cam01_median):
    """cam01 alone: the right forearm's plane swings about 120 degrees around the upper arm in frames 80-86 while the
    elbow is bent 90-128 degrees. The hinge axis follows it (it used to fall back to its default as they parted: the
    elbow turned 100 degrees in one frame, then bent sideways and backwards): no arm joint turns in a frame much more
    than the motion's own bones do, and the bent elbow bends forwards about its axis."""
    joints = cam01_median
    offsets = fit_skeleton(joints, np.ones(len(joints), bool))
    _, rot, _ = motion_channels(joints, offsets)
    arms = [JOINT_NAMES.index(n) for n in ("left_shoulder", "left_elbow", "right_shoulder", "right_elbow")]
    assert joint_steps(rot)[:, arms].max() < 1.2 * _largest_bone_turn(joints)
    bend, cos = hinge_alignment(rot, to_bvh_axes(joints), offsets)
    right_arm = list(LIMBS).index(JOINT_NAMES.index("right_shoulder"))
    cos = cos[bend[:, right_arm] > 60, right_arm]
    assert cos.size > 50 and (cos > 0).all() and np.median(cos) > np.cos(np.radians(10))


def test_hinge_axes_continue_across_chunks(cam01_median, tmp_path, monkeypatch):
    """Written in chunks whose border falls inside the swing, the BVH is the same file: each chunk's hinge axes
    continue from the last frame of the chunk before (starting again from the default axes they would differ)."""
    joints = cam01_median
    write_bvh(joints, 60.0, tmp_path / "whole.bvh")
    monkeypatch.setattr(frames, "CHUNK_FRAMES", 42)  # borders at frames 42 and 84
    write_bvh(joints, 60.0, tmp_path / "chunked.bvh")
    assert (tmp_path / "chunked.bvh").read_bytes() == (tmp_path / "whole.bvh").read_bytes()
    positions = to_bvh_axes(joints)
    offsets = fit_skeleton(joints, np.ones(len(joints), bool))
    whole, _ = fit_rotations(positions, offsets)
    _, state = fit_rotations(positions[:84], offsets)
    np.testing.assert_array_equal(fit_rotations(positions[84:], offsets, state)[0], whole[84:])
    fresh, _ = fit_rotations(positions[84:], offsets)
    assert np.abs(fresh - whole[84:]).max() > 0.1
