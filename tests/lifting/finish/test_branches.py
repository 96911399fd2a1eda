"""One view's depth branches chosen over a whole motion (lifting/finish/branches.py)."""

from __future__ import annotations

import numpy as np

from platypose.lifting.anatomy.hinges import HINGE_JOINTS, signed_flexion
from platypose.lifting.finish.branches import ray_sphere_points, viterbi
from platypose.lifting.finish.rigid import rigid_motion, rigid_paths
from platypose.lifting.finish.rigid_shape import RigidShape, clip_shape
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.timebase import resample


def _walk(real_clips, frames: int = 90) -> np.ndarray:
    walk = next(m for m in real_clips if "walk" in m.name)
    motion = resample(walk.joints, walk.fps, 30.0)[:frames]
    return motion - motion[:, 0].mean(0) + [0.0, 0.0, 1.0]


def _other_branch(motion: np.ndarray, centre: np.ndarray, top: int, mid: int, low: int) -> np.ndarray:
    """``motion`` ``(T, 17, 3)`` with one limb's middle joint moved to the other point of its ray at its bone's length
    from the root, and the end to the point of its ray at its bone's length from there (same image, other depth)."""
    out = motion.copy()
    upper = np.linalg.norm(motion[:, mid] - motion[:, top], axis=-1)
    lower = np.linalg.norm(motion[:, low] - motion[:, mid], axis=-1)
    middles = ray_sphere_points(centre, motion[:, mid], motion[:, top], upper)  # (T, 2, 3)
    other = np.argmax(np.linalg.norm(middles - motion[:, mid, None], axis=-1), axis=1)
    out[:, mid] = middles[np.arange(len(out)), other]
    ends = ray_sphere_points(centre, motion[:, low], out[:, mid], lower)
    nearest = np.argmin(np.linalg.norm(ends - motion[:, low, None], axis=-1), axis=1)
    out[:, low] = ends[np.arange(len(out)), nearest]
    return out


def test_ray_sphere_points_lie_on_both_the_ray_and_the_sphere():
    centre = np.zeros(3)
    point = np.array([[0.0, 3.0, 0.1], [0.0, 3.0, 2.0]])  # the second ray passes the sphere by
    middle = np.array([[0.0, 3.0, 0.0], [0.0, 3.0, 0.0]])
    hits = ray_sphere_points(centre, point, middle, np.array([0.5, 0.5]))
    np.testing.assert_allclose(np.linalg.norm(hits - middle[:, None], axis=-1), 0.5, atol=1e-12)
    ray = point[0] / np.linalg.norm(point[0])
    np.testing.assert_allclose(np.cross(hits[0], ray), 0.0, atol=1e-12)
    assert hits[0, 0] @ ray < hits[0, 1] @ ray  # nearer first
    np.testing.assert_allclose(hits[1, 0], hits[1, 1])


def test_viterbi_stays_on_a_branch_unless_the_way_over_is_short():
    """Two branches 1 m apart whose unary costs alternate slightly: the pass keeps one; where they touch, it crosses."""
    T = 12
    branches = np.zeros((1, T, 2, 2, 3))
    branches[0, :, 1, :, 0] = 1.0
    unary = np.zeros((1, T, 2))
    unary[0, 1::2, 0] = 0.01  # every other frame prefers the far branch a little
    chosen = viterbi(unary, branches)
    assert len(set(chosen[0].tolist())) == 1
    branches[0, 6:, 1, :, 0] = 0.0  # from frame 6 the branches coincide; later frames strongly prefer branch 1
    unary[0, 6:, 0] = 1.0
    chosen = viterbi(unary, branches)
    assert (chosen[0, 6:] == 1).all()


def test_a_limb_whose_sampled_depth_flips_every_frame_is_fitted_on_one_branch(real_clips):
    """A real walk seen by one camera whose 'sampler' puts the left arm and the right leg on their other depth
    branch in every third frame (the image unchanged): placed frame by frame, the knee and elbow follow it there
    (9 cm off the truth in 5 % of points, a knee bent 11 degrees backwards); fitted over the motion they stay on
    the body's branch, near the truth, and no knee or elbow bends backwards or turns faster than 1,800 degrees a
    second."""
    truth = _walk(real_clips)
    (camera,) = ring_cameras(4)[:1]
    flipped = truth.copy()
    for hinge in (0, 3):  # right knee, left elbow
        flipped = _other_branch(flipped, camera.center, *HINGE_JOINTS[hinge])
    sampled = truth.copy()
    sampled[1::3] = flipped[1::3]
    limbs = [2, 3, 12, 13]
    assert np.linalg.norm(sampled[1::3, limbs] - truth[1::3, limbs], axis=-1).max() > 0.15
    seen = np.ones((len(truth), 17, 1), bool)
    fitted = rigid_paths(sampled[None], clip_shape(truth[None]), camera.center[None], seen, 30.0)[0]
    off = np.linalg.norm(fitted[:, limbs] - truth[:, limbs], axis=-1)
    assert np.percentile(off, 95) < 0.05, np.percentile(off, 95)
    flexion = signed_flexion(fitted)
    assert flexion.min() > -10.0
    assert np.abs(np.diff(flexion, axis=0)).max() * 30.0 < 1800.0


def test_four_views_keep_a_real_pose_through_the_limits(real_clips):
    """A real walk seen by four cameras, every joint off by 5 mm: the limits leave its pose as the rigid placement
    has it (within 5 mm), its knees and elbows bent as the truth's (within the noise's 10 degrees)."""
    truth = _walk(real_clips)
    centres = np.stack([c.center for c in ring_cameras(4)])
    noisy = truth + np.random.default_rng(11).normal(0.0, 0.005, truth.shape)
    seen = np.ones((len(truth), 17, 4), bool)
    shape = clip_shape(noisy[None])
    fitted = rigid_paths(noisy[None], shape, centres, seen, 30.0)[0]
    rows = RigidShape(np.repeat(shape.lengths, len(truth), 0), np.repeat(shape.bodies, len(truth), 0))
    placed = rigid_motion(noisy, rows, centres, seen)
    assert np.abs(fitted - placed).max() < 0.005
    np.testing.assert_allclose(signed_flexion(fitted), signed_flexion(truth), atol=10.0)  # 5 mm: up to 7 degrees
