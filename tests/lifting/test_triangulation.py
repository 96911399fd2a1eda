"""Triangulation: exact on synthetic distorted views, NaN when under-observed, ~12 px on the real Pose2Sim keypoints."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from platypose.lifting.calibration import load_calibration
from platypose.lifting.camera import project
from platypose.lifting.triangulation import (
    associate_single_person,
    median_reprojection_error,
    reprojection_errors,
    triangulate,
    view_median_errors,
)

DEMO = "video/pose2sim-balancing"


@pytest.fixture(scope="module")
def cameras(data_dir: Path):
    return load_calibration(data_dir / DEMO / "calib_pose2sim.toml").cameras


def test_exact_on_synthetic_views(cameras):
    rng = np.random.default_rng(5)
    points = rng.uniform([-1.2, -0.8, 0.0], [0.0, 0.8, 1.8], size=(6, 17, 3))
    pixels = np.stack([project(points, cam) for cam in cameras])  # (C, 6, 17, 2), with distortion
    conf = rng.uniform(0.2, 1.0, size=pixels.shape[:-1])
    result = triangulate(pixels, conf, cameras)
    assert result.shape == (6, 17, 3)
    assert np.abs(result - points).max() < 1e-6
    assert np.abs(reprojection_errors(result, pixels, cameras)).max() < 1e-4


def test_confidence_and_missing_views(cameras):
    rng = np.random.default_rng(6)
    points = rng.uniform([-1.0, -0.5, 0.2], [-0.5, 0.5, 1.6], size=(17, 3))
    pixels = np.stack([project(points, cam) for cam in cameras])
    noisy = pixels.copy()
    noisy[0] += 40.0  # a bad view ...
    conf = np.ones((4, 17))
    conf[0] = 0.0  # ... with no confidence is ignored
    assert np.abs(triangulate(noisy, conf, cameras) - points).max() < 1e-6
    conf[1:3, :5] = 0.0  # joints 0-4 seen by camera 4 only
    noisy[1:3, :5] = np.nan
    result = triangulate(noisy, conf, cameras)
    assert np.isnan(result[:5]).all() and np.abs(result[5:] - points[5:]).max() < 1e-6


def _read_body25b_views(folder: Path) -> list[np.ndarray]:
    """Per view (T, P, 17, 3) of the first 17 BODY_25B points (COCO order), with the json module."""
    views = []
    for view in sorted(folder.iterdir()):
        frames = [json.loads(f.read_text())["people"] for f in sorted(view.glob("*.json"))]
        P = max(len(people) for people in frames)
        arr = np.zeros((len(frames), P, 17, 3))
        for t, people in enumerate(frames):
            for p, person in enumerate(people):
                arr[t, p] = np.reshape(person["pose_keypoints_2d"], (-1, 3))[:17]
        views.append(arr)
    return views


def test_pose2sim_keypoints_reproject_near_12_px(data_dir: Path, cameras):
    views = _read_body25b_views(data_dir / DEMO / "openpose-body25b")
    keypoints = associate_single_person(views, cameras)
    assert keypoints.shape == (4, 100, 17, 3)
    points = triangulate(keypoints[..., :2], keypoints[..., 2], cameras)
    error = median_reprojection_error(points, keypoints, cameras)
    assert 10.0 < error < 15.0  # measured 13.1 px
    per_view = view_median_errors(points, keypoints, cameras)
    assert np.all((per_view > 5.0) & (per_view < 25.0))
    # the triangulated person stands in the middle of the lab: ankles near the floor, nose 1.3-1.6 m up
    assert np.nanmedian(points[:, 15:17, 2]) < 0.3 and 1.3 < np.nanmedian(points[:, 0, 2]) < 1.6
    # every view takes part in every frame: no view was dropped to lower the error
    assert ((keypoints[..., 2] > 0).mean(axis=-1) >= 0.5).all()


def test_rays_meeting_only_at_infinity_are_nan_and_interpolate_without_a_warning():
    """Two cameras side by side, both seeing the point at their principal point: the rays are parallel, the DLT's
    homogeneous w is 0. The point is NaN (it was +-inf, and the lift's root interpolation then warned on inf * 0)."""
    from platypose.lifting.camera import Camera
    from platypose.lifting.timebase import interpolate
    from platypose.lifting.tracks.roots import fill_gaps

    K = np.array([[1000.0, 0.0, 960.0], [0.0, 1000.0, 540.0], [0.0, 0.0, 1.0]])
    left, right = Camera("left", (1080, 1920), K), Camera("right", (1080, 1920), K, t=np.array([-1.0, 0.0, 0.0]))
    centre = np.array([960.0, 540.0])
    met = project(np.array([0.5, 0.1, 4.0]), left), project(np.array([0.5, 0.1, 4.0]), right)
    pixels = np.stack([np.stack([met[0], centre, met[0]]), np.stack([met[1], centre, met[1]])])[:, :, None]  # (2,3,1,2)
    points = triangulate(pixels, np.ones((2, 3, 1)), [left, right])[:, 0]  # (3 frames, 3)
    assert np.isnan(points[1]).all()
    np.testing.assert_allclose(points[[0, 2]], [[0.5, 0.1, 4.0]] * 2, atol=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        path = interpolate(points, np.arange(3.0), np.array([0.0, 0.5, 2.0]))
        filled = fill_gaps(points, np.arange(3.0))
    np.testing.assert_allclose(path[[0, 2]], [[0.5, 0.1, 4.0]] * 2, atol=1e-9)
    np.testing.assert_allclose(filled[1], [0.5, 0.1, 4.0], atol=1e-9)
