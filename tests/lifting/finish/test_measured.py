"""Lasting offsets from what several views measure: the exact minimiser per frame, one view and far points left,
jitter left to the noise fit; on the real four-camera take's calibration and keypoints."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.lifting.calibration import load_calibration
from platypose.lifting.camera import project
from platypose.lifting.finish.measured import FARTHEST_M, SAMPLER_WEIGHT, image_pull, measure, steady_shift
from platypose.lifting.triangulation import associate_single_person, triangulate, view_median_errors

TAKE = "video/pose2sim-balancing"


@pytest.fixture(scope="module")
def cameras(data_dir: Path):
    return load_calibration(data_dir / TAKE / "calib_pose2sim.toml").cameras


def seen_by(points: np.ndarray, cameras, confidence: np.ndarray) -> np.ndarray:
    """Keypoints ``(C, T, 17, 3)`` of world ``points`` ``(T, 17, 3)`` with the given confidence ``(C, T, 17)``."""
    pixels = np.stack([project(points, cam) for cam in cameras])
    return np.concatenate([pixels, confidence[..., None]], axis=-1)


def objective(x: np.ndarray, x0: np.ndarray, truth: np.ndarray, cameras, confidence: np.ndarray) -> float:
    """The module's sum for one joint: squared distances across each view's ray through ``truth``, and to ``x0``."""
    total = SAMPLER_WEIGHT * np.sum((x - x0) ** 2)
    for cam, c in zip(cameras, confidence):
        ray = (truth - cam.center) / np.linalg.norm(truth - cam.center)
        across = (x - truth) - np.dot(x - truth, ray) * ray
        total += c * np.sum(across**2)
    return float(total)


def test_the_pull_is_the_exact_minimiser_of_images_and_prior(cameras):
    rng = np.random.default_rng(3)
    truth = rng.uniform([-1.0, -0.5, 0.2], [0.0, 0.5, 1.6], size=(4, 17, 3))
    confidence = rng.uniform(0.3, 1.0, size=(len(cameras), 4, 17))
    sampler = truth + rng.normal(0.0, 0.03, size=truth.shape)
    pulled = sampler + image_pull(sampler, measure(seen_by(truth, cameras, confidence), cameras))
    assert np.linalg.norm(pulled - truth, axis=-1).mean() < 0.5 * np.linalg.norm(sampler - truth, axis=-1).mean()
    t, j = 2, 5  # the minimum: no small step lowers the sum
    best = objective(pulled[t, j], sampler[t, j], truth[t, j], cameras, confidence[:, t, j])
    for step in np.concatenate([np.eye(3), -np.eye(3)]) * 1e-4:
        assert objective(pulled[t, j] + step, sampler[t, j], truth[t, j], cameras, confidence[:, t, j]) > best


def test_one_view_far_points_and_absent_frames_do_not_move(cameras):
    rng = np.random.default_rng(4)
    truth = rng.uniform([-1.0, -0.5, 0.2], [0.0, 0.5, 1.6], size=(3, 17, 3))
    confidence = np.ones((len(cameras), 3, 17))
    confidence[1:, 0] = 0.0  # frame 0: one view alone
    sampler = truth + 0.02
    sampler[1, 4] = truth[1, 4] + [FARTHEST_M + 0.05, 0.0, 0.0]  # the views disagree with the prior there
    sampler[2] = np.nan  # absent
    pull = image_pull(sampler, measure(seen_by(truth, cameras, confidence), cameras))
    assert (pull[0] == 0).all() and (pull[1, 4] == 0).all() and (pull[2] == 0).all()
    assert np.linalg.norm(sampler[1, :4] + pull[1, :4] - truth[1, :4], axis=-1).max() < 0.01


def test_a_lasting_offset_is_shifted_away_and_jitter_is_not_followed(cameras):
    """An answer 3 cm off the measured motion for 2 s, with 1 cm of frame-to-frame jitter on the keypoints' side:
    the shift takes most of the offset and none of the jitter, the same over a gap's two runs."""
    rng = np.random.default_rng(6)
    T, fps = 120, 60.0
    truth = rng.uniform([-1.0, -0.5, 0.2], [0.0, 0.5, 1.6], size=(1, 17, 3)) + np.linspace(0, 0.3, T)[:, None, None]
    measured = truth + rng.normal(0.0, 0.01, size=truth.shape)  # what the views triangulate: the truth, jittered
    answer = truth + [0.03, -0.02, 0.01]
    answer[50:55] = np.nan  # absent: two runs
    shift = steady_shift(answer, measure(seen_by(measured, cameras, np.ones((len(cameras), T, 17))), cameras), fps)
    present = np.isfinite(answer).all(axis=(1, 2))
    off = np.linalg.norm(answer + shift - truth, axis=-1)[present]
    assert np.median(off) < 0.012  # from 37 mm
    assert np.abs(np.diff(shift[60:], axis=0)).max() < 0.002  # no frame-to-frame jitter taken on
    assert (shift[~present] == 0).all()


def test_real_keypoints_of_four_views(data_dir: Path, cameras):
    """On the take's OpenPose keypoints, an answer 3 cm off everywhere ends nearer the images in every view."""
    folders = [data_dir / TAKE / "openpose-body25b" / f"cam0{c}_json" for c in range(1, len(cameras) + 1)]
    views = [read_openpose_folder(f, fps=60.0, image_size=(1920, 1088)).keypoints[:60] for f in folders]
    keypoints = associate_single_person(views, cameras)  # (C, 60, 17, 3)
    points = triangulate(keypoints[..., :2], keypoints[..., 2], cameras)
    answer = np.where(np.isfinite(points), points, np.nanmedian(points, axis=0)) + [0.03, 0.0, -0.02]
    shifted = answer + steady_shift(answer, measure(keypoints, cameras), 60.0)
    before, after = (view_median_errors(x, keypoints, cameras) for x in (answer, shifted))
    assert (after < before).all() and after.mean() < 0.8 * before.mean(), (before, after)  # the views disagree
