"""Rigid lifts (platypose.lifting.finish.rigid, rigid_shape): the geometry against brute force, real motion, real lifts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from platypose.detectors.persons.multiview import match_across_views
from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.exporters.bvh import write_bvh
from platypose.lifting.anatomy.limits import hinge_coordinates, limit_excess
from platypose.lifting.calibration import load_calibration
from platypose.lifting.camera import project
from platypose.lifting.checks.plausibility import stance_slides
from platypose.lifting.finish.rigid import person_shape, place_on_sphere, rigid_motion, rigid_paths, rigid_person
from platypose.lifting.finish.rigid_shape import RigidShape, body_frames, body_offsets, clip_shape
from platypose.lifting.finish.smoothing import smooth_over_time
from platypose.lifting.finish.stance_legs import two_bone_limb
from platypose.lifting.floor import CALIBRATED_FLOOR
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.rotations import rotvec_matrices
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.skeleton import bone_lengths
from platypose.lifting.take import Take
from platypose.lifting.timebase import resample
from platypose.lifting.tracks.persons import lift_persons
from platypose.lifting.triangulation import triangulate, view_median_errors
from platypose.pipeline import lift_take

TAKE = "video/pose2sim-balancing"
NAMES = ("cam01", "cam02", "cam03", "cam04")


def _local_bodies(joints: np.ndarray) -> np.ndarray:
    """Each body's children in its own frame, (..., B, 3, 3): constant over frames for a rigid motion."""
    offsets = body_offsets(joints)
    return np.einsum("...bji,...bkj->...bki", body_frames(offsets), offsets)


def _walk(real_clips, frames: int = 60) -> np.ndarray:
    walk = next(m for m in real_clips if "walk" in m.name)
    motion = resample(walk.joints, walk.fps, 30.0)[:frames]
    return motion - motion[:, 0].mean(0) + [0.0, 0.0, 1.0]


@pytest.fixture(scope="module")
def athlete(data_dir: Path):
    """The Pose2Sim athlete: cameras, OpenPose keypoints of all four views ``(C, T, 1, 17, 3)``, frame times."""
    cameras = list(load_calibration(data_dir / TAKE / "calib_pose2sim.toml").cameras)
    views = [read_openpose_folder(data_dir / TAKE / "openpose-body25b" / f"{n}_json") for n in NAMES]
    matched = match_across_views(views, cameras)
    return cameras, np.stack([m.keypoints[:, :1] for m in matched]), matched[0].frame_times


def test_place_on_sphere_is_the_constrained_minimiser():
    """Against 20,000 points spread over each sphere: never worse than the best of them; on the sphere exactly."""
    rng = np.random.default_rng(0)
    M = 200
    a = rng.normal(size=(M, 3, 3))
    weight = a @ np.swapaxes(a, 1, 2) + 0.01 * np.eye(3)
    centre = rng.normal(size=(M, 3))
    target = centre + 0.3 * rng.normal(size=(M, 3))
    radius = rng.uniform(0.1, 0.5, M)
    x = place_on_sphere(target, weight, centre, radius)
    np.testing.assert_allclose(np.linalg.norm(x - centre, axis=1), radius, atol=1e-12)
    k = np.arange(20000) + 0.5
    polar, turn = np.arccos(1 - 2 * k / 20000), np.pi * (1 + 5**0.5) * k
    sphere = np.stack([np.cos(turn) * np.sin(polar), np.sin(turn) * np.sin(polar), np.cos(polar)], -1)
    for m in range(M):
        d = centre[m] + radius[m] * sphere - target[m]
        best = np.einsum("ka,ab,kb->k", d, weight[m], d).min()
        found = (x[m] - target[m]) @ weight[m] @ (x[m] - target[m])
        assert found <= best + 1e-9, (m, found, best)


def test_rotvec_matrices_equal_scipy():
    from scipy.spatial.transform import Rotation

    rotvec = np.random.default_rng(4).normal(size=(500, 3))
    rotvec[0], rotvec[1] = 0.0, 1e-13
    np.testing.assert_allclose(rotvec_matrices(rotvec), Rotation.from_rotvec(rotvec).as_matrix(), atol=1e-14)


def test_smooth_over_time_solves_its_banded_system():
    rng = np.random.default_rng(1)
    for T in (3, 4, 9):
        second = np.zeros((T - 2, T))
        for r in range(T - 2):
            second[r, r : r + 3] = (1.0, -2.0, 1.0)
        values = rng.normal(size=(T, 4, 3))
        expected = np.linalg.solve(np.eye(T) + 2.5 * second.T @ second, values.reshape(T, -1)).reshape(values.shape)
        np.testing.assert_allclose(smooth_over_time(values, 2.5), expected, atol=1e-12)
    np.testing.assert_array_equal(smooth_over_time(values[:2], 2.5), values[:2])


def test_one_view_puts_real_motion_back_on_its_rays(real_clips):
    """A real walk seen by one camera, every joint but the pelvis slid along its ray by up to 3 cm (so bones
    stretch by centimetres and the image does not change): made rigid with the walk's shape, each joint
    returns near its true place and its projection stays within a pixel."""
    truth = _walk(real_clips)
    (camera,) = ring_cameras(4)[:1]
    rng = np.random.default_rng(2)
    ray = truth - camera.center
    slide = rng.uniform(-0.03, 0.03, truth.shape[:2] + (1,))
    slide[:, 0] = 0.0
    stretched = truth + slide * ray / np.linalg.norm(ray, axis=-1, keepdims=True)
    assert np.abs(bone_lengths(stretched) - bone_lengths(truth)).max() > 0.02
    T = len(truth)
    shape = clip_shape(truth)
    rows = RigidShape(np.broadcast_to(shape.lengths, (T, 16)), np.broadcast_to(shape.bodies, (T, 2, 3, 3)))
    rigid = rigid_motion(stretched, rows, camera.center[None], np.ones((T, 17, 1), bool))
    np.testing.assert_allclose(bone_lengths(rigid), np.broadcast_to(shape.lengths, (T, 16)), atol=1e-9)
    np.testing.assert_allclose(_local_bodies(rigid), np.broadcast_to(shape.bodies, (T, 2, 3, 3)), atol=1e-9)
    moved_px = np.linalg.norm(project(rigid, camera) - project(truth, camera), axis=-1)
    assert np.median(moved_px) < 0.05 and moved_px.max() < 1.0, (np.median(moved_px), moved_px.max())
    off = np.linalg.norm(rigid - truth, axis=-1)
    assert np.median(off) < 0.005 < np.median(np.linalg.norm(stretched - truth, axis=-1)), np.median(off)


def test_rigid_paths_are_rigid_smooth_and_above_the_floor(real_clips):
    """One view: bones and bodies keep the shape in every frame, the frame-to-frame jitter of joints around a
    smooth pelvis is damped, no frame goes under the floor, a frame missing (NaN) stays missing. Four views:
    each frame's hips, trunk and shoulders are placed alone (no smoothing), knees and elbows held within their
    limits and steadied, all nearer the truth than the noisy motion."""
    truth = _walk(real_clips)
    rng = np.random.default_rng(3)
    noisy = truth.copy()
    noisy[:, 1:] += rng.normal(0.0, 0.01, noisy[:, 1:].shape)
    noisy[20] = np.nan
    cams = ring_cameras(4)
    centres = np.stack([c.center for c in cams])
    shape = clip_shape(noisy[None])
    seen = np.ones((len(truth), 17, 1), bool)
    rigid = rigid_paths(noisy[None], shape, centres[:1], seen, 30.0, CALIBRATED_FLOOR)[0]
    on = np.isfinite(rigid).all(axis=(1, 2))
    assert not on[20] and on.sum() == len(truth) - 1
    lengths, bodies = shape.lengths[0], shape.bodies[0]
    np.testing.assert_allclose(bone_lengths(rigid[on]), np.broadcast_to(lengths, (on.sum(), 16)), atol=1e-9)
    np.testing.assert_allclose(_local_bodies(rigid[on]), np.broadcast_to(bodies, (on.sum(), 2, 3, 3)), atol=1e-9)
    assert (rigid[on][..., 2].min(axis=-1) >= np.minimum(noisy[on][..., 2].min(axis=-1), 0.0) - 1e-9).all()

    def jitter(x: np.ndarray) -> float:
        span = x[21:]
        return float(np.linalg.norm(span[2:] - 2 * span[1:-1] + span[:-2], axis=-1).mean())

    assert jitter(rigid) < 0.5 * jitter(noisy), (jitter(rigid), jitter(noisy))
    four = rigid_paths(noisy[None], shape, centres, np.ones((len(truth), 17, 4), bool), 30.0)[0]
    rows = RigidShape(np.broadcast_to(lengths, (len(truth), 16)), np.broadcast_to(bodies, (len(truth), 2, 3, 3)))
    placed = rigid_motion(noisy, rows, centres, np.ones((len(truth), 17, 4), bool))
    trunk = [0, 1, 4, 7, 8, 9, 10, 11, 14]  # hips, spine, head, shoulders: placed alone, as they are
    np.testing.assert_allclose(four[:, trunk], placed[:, trunk])
    np.testing.assert_allclose(bone_lengths(four[on]), np.broadcast_to(lengths, (on.sum(), 16)), atol=1e-9)
    assert limit_excess(*hinge_coordinates(four[on])).max() < 1e-3
    assert np.linalg.norm(four[on] - truth[on], axis=-1).mean() < np.linalg.norm(noisy[on] - truth[on], axis=-1).mean()


def test_a_gaps_guessed_frames_do_not_shape_the_body_the_seen_frames_measure(real_clips):
    """A real walk seen by one camera except in a gap of 35 of its 60 frames, where the prior's guess has shins 15 %
    longer: the body's shape is the seen frames' (shape over every frame: shins a centimetre and more off), so
    the seen frames keep their true bones and their image."""
    truth = _walk(real_clips)
    (camera,) = ring_cameras(4)[:1]
    gap = np.zeros(len(truth), bool)
    gap[15:50] = True
    guessed = truth.copy()
    for knee, ankle in ((2, 3), (5, 6)):
        guessed[gap, ankle] = truth[gap, knee] + 1.15 * (truth[gap, ankle] - truth[gap, knee])
    true_shape = person_shape(truth[None, ~gap], 1)  # the shape the seen frames measure
    np.testing.assert_allclose(person_shape(guessed[None], 1, ~gap).lengths, true_shape.lengths, atol=1e-12)
    assert np.abs(person_shape(guessed[None], 1).lengths - true_shape.lengths)[0, [2, 5]].min() > 0.01

    keypoints = np.concatenate([project(truth, camera), np.ones(truth.shape[:2] + (1,))], axis=-1)
    keypoints[gap, :, 2] = 0.0
    hypotheses, median = guessed[None, None].copy(), guessed[None].copy()
    rigid_person(hypotheses, median, keypoints[None, :, None], [camera], 0, 30.0)
    seen_lengths = bone_lengths(hypotheses[0, 0, ~gap])
    np.testing.assert_allclose(seen_lengths, np.broadcast_to(true_shape.lengths, seen_lengths.shape), atol=1e-6)
    moved_px = np.linalg.norm(project(hypotheses[0, 0, ~gap], camera) - keypoints[~gap, :, :2], axis=-1)
    assert np.median(moved_px) < 0.5, np.median(moved_px)


def test_two_bone_limb_reaches_its_target_with_exact_bones():
    """Reachable targets are met exactly, out-of-reach ones on the line at full stretch; both bones keep their
    lengths and the middle joint bends towards the pole."""
    rng = np.random.default_rng(1)
    M = 500
    root, pole = rng.normal(size=(M, 3)), rng.normal(size=(M, 3))
    upper, lower = rng.uniform(0.3, 0.5, M), rng.uniform(0.3, 0.5, M)
    direction = rng.normal(size=(M, 3))
    direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
    reach = rng.uniform(0.5, 1.5, M) * (upper + lower)
    middle, end = two_bone_limb(root, root + reach[:, None] * direction, pole, upper, lower)
    np.testing.assert_allclose(np.linalg.norm(middle - root, axis=-1), upper, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(end - middle, axis=-1), lower, atol=1e-9)
    expected = np.minimum(reach, upper + lower - 1e-6)[:, None] * direction
    ok = reach > np.abs(upper - lower) + 1e-6
    np.testing.assert_allclose((end - root)[ok], expected[ok], atol=1e-9)
    side = (pole - root) - np.sum((pole - root) * direction, -1, keepdims=True) * direction
    bent = reach < upper + lower - 1e-3
    assert (np.sum((middle - root) * side, axis=-1)[bent] > 0).all()


def test_one_view_rigid_feet_stand_still(real_clips):
    """A real walk with 1 cm of noise on every joint, made rigid for one view: the feet that stand in it stand still
    (their slide along the floor far below the noisy motion's), the bones keep one length."""
    truth = _walk(real_clips)
    noisy = truth + np.random.default_rng(5).normal(0.0, 0.01, truth.shape)
    shape = clip_shape(noisy[None])
    centres = np.stack([c.center for c in ring_cameras(4)])[:1]
    seen = np.ones((len(truth), 17, 1), bool)
    rigid = rigid_paths(noisy[None], shape, centres, seen, 30.0, CALIBRATED_FLOOR)
    np.testing.assert_allclose(bone_lengths(rigid[0]), np.broadcast_to(shape.lengths[0], (len(truth), 16)), atol=1e-9)
    before, after = stance_slides(noisy[None], CALIBRATED_FLOOR), stance_slides(rigid, CALIBRATED_FLOOR)
    assert after.size > 0.3 * before.size
    assert np.median(after) < 0.25 * np.median(before), (np.median(after), np.median(before))


def test_a_real_lift_is_rigid_and_keeps_its_image(tiny_prior, athlete):
    """The Pose2Sim athlete seen by cam01 (OpenPose, 40 frames), lifted with the tiny prior: every hypothesis and
    the median keep one length per bone and one shape per body to 0.01 mm, no frame sinks under the floor, and
    the hypotheses' projections move by under 3 px (median; this prior stretches bones by decimetres)."""
    cameras, keypoints, times = athlete
    kp, t = keypoints[:1, :40], times[:40]
    config = SamplerConfig(samples=4, steps=4, skip=1, guidance_iters=2, floor=CALIBRATED_FLOOR.plane)
    settings = WindowSettings(16, 4)
    take = Take.on_clock(kp, t, np.array([0]), cameras[:1], [None], sampler=config, windows=settings)
    result = lift_take(tiny_prior, take, floor=CALIBRATED_FLOOR)
    hyps, median = np.asarray(result.hypotheses[0], np.float64), np.asarray(result.median[0], np.float64)
    for motion in (*hyps, median):
        lengths = bone_lengths(motion)
        assert np.abs(lengths - lengths[0]).max() < 1e-5
        bodies = _local_bodies(motion)
        assert np.abs(bodies - bodies[0]).max() < 1e-5
    before_h, before_m, energy = np.zeros((1, 4, 40, 17, 3)), np.zeros((1, 40, 17, 3)), np.zeros((1, 4, 40))
    torch.manual_seed(0)
    lift_persons(tiny_prior, take, hypotheses=before_h, median=before_m, energy=energy)
    stretch = np.abs(bone_lengths(before_h[0]) - np.median(bone_lengths(before_h[0]), axis=1, keepdims=True)).max()
    assert stretch > 0.01  # the sampler's bones do stretch
    moved = np.linalg.norm(project(hyps, cameras[0]) - project(before_h[0], cameras[0]), axis=-1)
    assert np.median(moved) < 3.0, np.median(moved)
    lowest, was = hyps[..., 2].min(axis=-1), before_h[0][..., 2].min(axis=-1)
    assert (lowest >= np.minimum(was, 0.0) - 1e-5).all()
    assert result.meta["rigid_bones"]["p0"]["stretch_m"] > 0.0


def test_four_views_correct_a_lasting_offset_and_keep_the_spread(athlete):
    """The athlete's four views (OpenPose, 60 frames): hypotheses 3 cm off the keypoints' triangulation for the
    whole clip, spread 2 cm about it, are made rigid nearer the keypoints in every view, still as spread
    (lifting.finish.measured)."""
    cameras, keypoints, times = athlete
    kp = keypoints[:, :60]  # (C, T, 1, 17, 3)
    points = triangulate(kp[:, :, 0, :, :2], kp[:, :, 0, :, 2], cameras)
    points = np.where(np.isfinite(points), points, np.nanmedian(points, axis=0))  # a joint seen once: its median
    spread = np.random.default_rng(2).normal(0.0, 0.02, size=(1, 6, 1, 17, 3))  # one offset per hypothesis
    hypotheses = points + [0.03, -0.02, 0.0] + spread
    median = np.median(hypotheses, axis=1)
    before = view_median_errors(median[0], kp[:, :, 0], cameras)
    width = np.std(hypotheses[0], axis=0).mean()
    rigid_person(hypotheses, median, kp, cameras, 0, 60.0)
    after = view_median_errors(median[0], kp[:, :, 0], cameras)
    assert (after < before).all() and after.mean() < 0.9 * before.mean(), (before, after)  # the views disagree
    assert 0.8 < np.std(hypotheses[0], axis=0).mean() / width < 1.2


@pytest.mark.slow  # the shipped prior
@pytest.mark.parametrize("views", [1, 4])
def test_the_bvh_of_a_real_lift_fits_its_median_within_10_mm(athlete, views, tmp_path):
    """The Pose2Sim athlete (100 frames of OpenPose, cam01 alone or all four views), lifted with the shipped prior:
    the BVH of the median motion is within mean 10 mm, max 40 mm of it (the target; the sampler's own
    motion stretches bones by 9-15 cm, which kept the fit at 24 mm mean, 112 mm max for cam01)."""
    from platypose.lifting.prior.model import load_prior

    torch.set_num_threads(1)
    prior = load_prior()[0]
    cameras, keypoints, times = athlete
    config = SamplerConfig(samples=10, floor=CALIBRATED_FLOOR.plane)
    root = [None] if views == 1 else None
    if root is None:
        from platypose.lifting.tracks.persons import root_paths

        root = root_paths(keypoints, times, cameras)
    take = Take.on_clock(
        keypoints[:views], times, np.array([0]), cameras[:views], root, sampler=config, windows=WindowSettings()
    )
    result = lift_take(prior, take, floor=CALIBRATED_FLOOR)
    fit = write_bvh(result.median[0], result.fps, tmp_path / "athlete.bvh")
    assert fit.mean_m <= 0.010 and fit.max_m <= 0.040, fit
    assert fit.stretch_m < 1e-4, fit
