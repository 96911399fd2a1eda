"""Knee and elbow limits, and moving a limb back inside them (lifting/anatomy/limits.py)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from platypose.lifting.anatomy.hinges import HINGE_JOINTS, neck_cosine, signed_flexion
from platypose.lifting.anatomy.limits import (
    FLEXION_RANGE_DEG,
    HEAD_LIMIT_DEG,
    TWIST_LIMITS_DEG,
    hinge_coordinates,
    limit_excess,
    within_limits,
)
from platypose.lifting.skeleton import JOINT_INDEX as J
from platypose.lifting.skeleton import bone_lengths
from platypose.lifting.timebase import resample


def _head_angles(joints: np.ndarray) -> np.ndarray:
    """Degrees between the trunk's line and the head's."""
    return np.degrees(np.arccos(np.clip(neck_cosine(torch.as_tensor(joints)).numpy(), -1.0, 1.0)))


def _real_motion(real_clips) -> np.ndarray:
    """Every frame of the bundled real clips on our skeleton, 30 fps."""
    return np.concatenate([resample(clip.joints, clip.fps, 30.0) for clip in real_clips])


def test_hinge_coordinates_read_signed_flexion_and_a_quarter_turn_of_twist(real_clips):
    """The flexion read is :func:`signed_flexion`'s (the two are one definition), the twist within a quarter turn."""
    motion = _real_motion(real_clips)[::7]
    flexion, twist = hinge_coordinates(motion)
    np.testing.assert_allclose(flexion, signed_flexion(motion), atol=1e-6)
    assert np.abs(twist).max() <= 90.0 + 1e-9


def test_real_motion_capture_is_almost_all_inside_the_limits(real_clips):
    """Limits a body holds: of real motion capture (climbing, DeepMimic's acrobatics), at most 4 % of the frames of any
    hinge lie outside them."""
    flexion, twist = hinge_coordinates(_real_motion(real_clips))
    outside = (limit_excess(flexion, twist) > 0).mean(axis=0)
    assert outside.max() < 0.04, outside


@pytest.mark.parametrize("noise_m", [0.03, 0.08])
def test_within_limits_holds_every_limb_of_noisy_motion_and_keeps_its_bones(real_clips, noise_m):
    """Real motion with centimetres of noise on every joint (knees and elbows thrown past their limits in many
    frames): afterwards no hinge is past a limit, every bone keeps its length, hips, shoulders, ankles and wrists
    stay where they were, and limbs already inside do not move."""
    motion = _real_motion(real_clips)[::5]
    noisy = motion + np.random.default_rng(7).normal(0.0, noise_m, motion.shape)
    before = limit_excess(*hinge_coordinates(noisy))
    assert (before > 0).any(axis=-1).mean() > 0.05
    held = within_limits(noisy)
    assert limit_excess(*hinge_coordinates(held)).max() < 1e-6
    np.testing.assert_allclose(bone_lengths(held), bone_lengths(noisy), atol=1e-9)
    limbs = [j for _, mid, low in HINGE_JOINTS for j in (mid, low)] + [J["head"]]
    kept = [j for j in range(17) if j not in limbs]
    np.testing.assert_allclose(held[:, kept], noisy[:, kept], atol=1e-9)
    ends = [low for _, _, low in HINGE_JOINTS]
    broken = before > 0
    ends_moved = np.linalg.norm(held[:, ends] - noisy[:, ends], axis=-1) > 1e-9
    assert ends_moved[broken].mean() < 0.3, ends_moved[broken].mean()  # mostly the knee or elbow alone turns
    assert _head_angles(held).max() <= HEAD_LIMIT_DEG + 1e-6
    inside = (before == 0).all(axis=-1) & (_head_angles(noisy) <= HEAD_LIMIT_DEG)
    np.testing.assert_array_equal(held[inside], noisy[inside])


def test_within_limits_turns_a_backward_knee_forward():
    """A leg whose shin folds forward from a hanging thigh (a knee bent 60 degrees backwards) is mended by turning
    the knee about the hip-ankle line onto the side where it bends forwards: flexion +60, ankle and hip in place."""
    joints = np.zeros((17, 3))
    joints[[1, 4]] = [[-0.1, 0, 1.0], [0.1, 0, 1.0]]  # left +x, forward -y, up +z: hips
    joints[7], joints[8], joints[9], joints[10] = [0, 0, 1.25], [0, 0, 1.5], [0, 0, 1.6], [0, 0, 1.75]
    joints[[11, 14]] = [[0.18, 0, 1.5], [-0.18, 0, 1.5]]
    joints[[12, 15]] = joints[[11, 14]] - [0, 0, 0.28]
    joints[[13, 16]] = joints[[12, 15]] - [0, 0, 0.25]
    bend = np.radians(60.0)
    for hip, knee, ankle in ((1, 2, 3), (4, 5, 6)):
        joints[knee] = joints[hip] - [0, 0, 0.42]
        joints[ankle] = joints[knee] + 0.41 * np.array([0, -np.sin(bend), -np.cos(bend)])  # shin forward: backwards
    flexion, _ = hinge_coordinates(joints)
    np.testing.assert_allclose(flexion[:2], [-60.0, -60.0], atol=1e-6)
    held = within_limits(joints)
    flexion, twist = hinge_coordinates(held)
    np.testing.assert_allclose(flexion[:2], [60.0, 60.0], atol=1e-6)
    assert (np.abs(twist[:2]) <= TWIST_LIMITS_DEG[0]).all()
    np.testing.assert_allclose(held[[1, 3, 4, 6]], joints[[1, 3, 4, 6]], atol=1e-12)
    assert FLEXION_RANGE_DEG[0] < 0.0
