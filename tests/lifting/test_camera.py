"""The camera model equals cv2.projectPoints, in numpy and in batched torch."""

import cv2
import numpy as np
import torch

from platypose.lifting.camera import Camera, CameraBatch, project, undistort_normalized


def _random_camera(rng: np.random.Generator, name: str) -> Camera:
    rvec = rng.normal(0, 0.5, 3)
    R, _ = cv2.Rodrigues(rvec)
    K = np.array([[1100 + 200 * rng.random(), 0, 500 + 40 * rng.random()], [0, 1150, 480], [0, 0, 1]])
    dist = np.array([-0.25, 0.12, 1e-3, -2e-3, -0.02]) * rng.random()
    return Camera(name, (1000, 1002), K, dist, R, np.array([0.1, -0.2, 5.0]))


def _cv2_project(points: np.ndarray, cam: Camera) -> np.ndarray:
    rvec, _ = cv2.Rodrigues(cam.R)
    out, _ = cv2.projectPoints(points.reshape(-1, 1, 3), rvec, cam.t, cam.K, cam.dist)
    return out.reshape(points.shape[:-1] + (2,))


def test_projection_matches_opencv_numpy_and_torch():
    rng = np.random.default_rng(0)
    cams = [_random_camera(rng, f"c{i}") for i in range(3)]
    points = rng.uniform(-1, 1, (7, 5, 3))
    expected = np.stack([_cv2_project(points, c) for c in cams])
    ours = np.stack([project(points, c) for c in cams])
    assert np.abs(ours - expected).max() < 1e-6
    batch = CameraBatch.from_cameras(cams, dtype=torch.float64)
    torch_px = batch.project(torch.as_tensor(points)).numpy()
    assert torch_px.shape == (3, 7, 5, 2)
    assert np.abs(torch_px - expected).max() < 1e-6


def test_projection_is_differentiable():
    cam = _random_camera(np.random.default_rng(1), "c")
    batch = CameraBatch.from_cameras([cam], dtype=torch.float64)
    points = torch.zeros(4, 3, dtype=torch.float64, requires_grad=True)
    batch.project(points).sum().backward()
    assert torch.isfinite(points.grad).all() and points.grad.abs().sum() > 0


def test_camera_center():
    cam = _random_camera(np.random.default_rng(2), "c")
    assert np.allclose(cam.R @ cam.center + cam.t, 0)


def test_undistort_inverts_projection_and_takes_no_points():
    cam = _random_camera(np.random.default_rng(3), "c")
    points = np.random.default_rng(4).uniform(-1, 1, (6, 4, 3))
    in_camera = points @ cam.R.T + cam.t
    normalized = undistort_normalized(project(points, cam), cam.K, cam.dist)
    assert normalized.shape == (6, 4, 2)
    assert np.abs(normalized - in_camera[..., :2] / in_camera[..., 2:]).max() < 1e-6
    assert undistort_normalized(np.zeros((0, 17, 2)), cam.K, cam.dist).shape == (0, 17, 2)


def test_a_wide_rational_lens_projects_and_undistorts_as_opencv():
    """OpenCV's rational model (k4 k5 k6 under k1 k2 k3: a wide barrel lens, what the scene's distortion gives
    such a camera) in numpy and torch equals cv2.projectPoints, and undistorting inverts it within a 90 degree
    field of view (OpenCV's default 5 iterations fall 5e-4 short here, half a pixel)."""
    rng = np.random.default_rng(5)
    cam = _random_camera(rng, "wide")
    cam = Camera("wide", cam.size, cam.K, [-0.52, 0.31, 1e-3, -2e-3, -0.04, -0.11, 0.12, -0.01], cam.R, cam.t)
    points = rng.uniform(-2, 2, (9, 6, 3))
    expected = _cv2_project(points, cam)
    assert np.abs(project(points, cam) - expected).max() < 1e-6
    torch_px = CameraBatch.from_cameras([cam], dtype=torch.float64).project(torch.as_tensor(points)).numpy()[0]
    assert np.abs(torch_px - expected).max() < 1e-6
    in_camera = points @ cam.R.T + cam.t
    rays = in_camera[..., :2] / in_camera[..., 2:]
    seen = np.abs(rays).max(axis=-1) < 1.0  # within a 90 degree field of view
    normalized = undistort_normalized(expected, cam.K, cam.dist)
    assert np.abs(normalized - rays)[seen].max() < 1e-6
