"""Pose2Sim / Sports2D .toml on the real files: values, projection equal to cv2.projectPoints, frame conversion, bad files."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from platypose.lifting.calibration import load_calibration
from platypose.lifting.camera import Camera, project
from platypose.lifting.errors import InputError

POSE2SIM = "video/pose2sim-balancing/calib_pose2sim.toml"
SPORTS2D = "video/sports2d-demo/Calib_demo.toml"


def random_points_in_front(camera: Camera, n: int = 200, seed: int = 0) -> np.ndarray:
    """World points (n, 3) 1-6 m in front of the camera, inside its image."""
    rng = np.random.default_rng(seed)
    h, w = camera.size
    pix = rng.uniform([0, 0], [w, h], size=(n, 2))
    rays = np.linalg.solve(camera.K, np.c_[pix, np.ones(n)].T).T
    cam_points = rays * rng.uniform(1.0, 6.0, size=(n, 1))
    return (cam_points - camera.t) @ camera.R


def assert_matches_opencv(camera: Camera, rvec, tvec, K, dist) -> None:
    """Our projection of random points equals cv2.projectPoints with the file's own parameters."""
    points = random_points_in_front(camera)
    expected = cv2.projectPoints(
        points, np.asarray(rvec, float), np.asarray(tvec, float), np.asarray(K, float), np.asarray(dist, float)
    )[0]
    assert np.abs(project(points, camera) - expected.reshape(-1, 2)).max() < 1e-6


def test_pose2sim_values(data_dir: Path):
    cal = load_calibration(data_dir / POSE2SIM)
    assert cal.names == ("cam_01", "cam_02", "cam_03", "cam_04")
    cam = cal.cameras[2]
    assert cam.size == (1920, 1088)  # file says [width, height] = [1088, 1920]
    assert cam.K[0, 0] == 1681.598388671875 and cam.K[0, 2] == 513.20837403125
    assert np.array_equal(cam.dist, [-0.000729765625, 0.00215034375, -8.46875e-06, -8.078125e-06, 0.0, 0.0, 0.0, 0.0])
    assert np.allclose(cam.R, cv2.Rodrigues(np.array([0.8109654899999995, -2.1972129299999996, 1.3760277799999996]))[0])
    # lab cameras stand 1.6-2.2 m high and look down: the file's world is Z up
    assert all(1.6 < c.center[2] < 2.2 and c.R[2, 2] < 0 for c in cal.cameras)
    assert cal.meta["format"] == "pose2sim-toml" and "assumed Z up" in cal.meta["assumptions"][0]


def test_pose2sim_projection_equals_opencv(data_dir: Path):
    import tomllib

    raw = tomllib.loads((data_dir / POSE2SIM).read_text())
    cal = load_calibration(data_dir / POSE2SIM)
    for camera in cal.cameras:
        table = raw[camera.name]
        assert_matches_opencv(camera, table["rotation"], table["translation"], table["matrix"], table["distortions"])


def test_sports2d_demo(data_dir: Path):
    cal = load_calibration(data_dir / SPORTS2D)
    (cam,) = cal.cameras
    assert cam.name == "demo" and cam.size == (994, 1768)
    assert cam.K[0, 0] == pytest.approx(2520.0897058227038)
    assert_matches_opencv(
        cam,
        [1.2082126924727719, 1.2098328575850605, -1.2082126924727719],
        [-3.510103521992233, 1.7079310029359385, 10.0],
        cam.K,
        np.zeros(4),
    )


def test_world_up_override_rotates_world(data_dir: Path):
    z_up = load_calibration(data_dir / POSE2SIM)
    y_up = load_calibration(data_dir / POSE2SIM, world_up="y")
    for a, b in zip(z_up.cameras, y_up.cameras):
        x, y, z = a.center
        assert np.allclose(b.center, [x, -z, y])
        point = np.array([0.2, -0.1, 1.0])
        assert np.allclose(project(point, a), project(np.array([0.2, -1.0, -0.1]), b))
    assert "world up axis y rotated to +z" in y_up.meta["conversions"]


def test_anipose_millimetre_file_units_detected(data_dir: Path):
    path = Path(__file__).parents[2] / "data/calib/anipose_mm.toml"
    cal = load_calibration(path)
    reference = load_calibration(data_dir / POSE2SIM)
    assert cal.names == ("A", "B") and "units mm scaled to metres (x0.001)" in cal.meta["conversions"]
    assert "millimetres detected (cameras a median 2854 units apart" in cal.meta["assumptions"][0]
    for ours, ref in zip(cal.cameras, reference.cameras):
        assert np.allclose(ours.t, ref.t) and np.array_equal(ours.K, ref.K) and ours.size == ref.size
        assert_matches_opencv(ours, cv2.Rodrigues(ref.R)[0], ref.t, ref.K, ref.dist)
    with pytest.raises(InputError, match="a camera is 3166 m from the origin; the units look wrong .file read as m."):
        load_calibration(path, units="m")


def test_missing_intrinsics_and_extrinsics_use_defaults(data_dir: Path, tmp_path: Path):
    text = (data_dir / SPORTS2D).read_text()
    for line in text.splitlines():
        if line.startswith(("matrix", "rotation", "translation")):
            text = text.replace(line + "\n", "")
    path = tmp_path / "bare.toml"
    path.write_text(text)
    cal = load_calibration(path)
    (cam,) = cal.cameras
    assert cam.K[0, 0] == pytest.approx(np.hypot(1768, 994)) and (cam.K[0, 2], cam.K[1, 2]) == (884.0, 497.0)
    assert np.array_equal(cam.center, np.zeros(3)) and np.allclose(cam.R @ [0, 0, 1], [0, -1, 0])
    notes = " ".join(cal.meta["assumptions"])
    assert "no intrinsics: focal 2028.3 px" in notes and "no extrinsics: camera at the world origin" in notes


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("fisheye = false", "fisheye = true", "fisheye model"),
        ("size = [ 1088.0, 1920.0]", "", "missing size"),
        ("[ 0.0, 0.0, 1.0]]", "[ 0.0, 0.0, 1.0], [1, 2, 3]]", "matrix has 12 values"),
        (
            "rotation = [ 1.6882754799999993, 1.0483220499999997, -0.41955852000000016]",
            "rotation = [ [1, 0, 0], [0, 1, 0], [0, 0, 3]]",
            "not a rotation",
        ),
        ("translation = [ 0.3211048899999996, 0.9563320600000009, 2.8907130499999996]", "", "only one of rotation"),
        ("[cam_01]", "[cam_01", "not valid TOML"),
    ],
)
def test_broken_toml(data_dir: Path, tmp_path: Path, old, new, message):
    text = (data_dir / POSE2SIM).read_text()
    assert old in text
    path = tmp_path / "broken.toml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(InputError, match=message) as err:
        load_calibration(path)
    assert str(path) in str(err.value)
