"""Native calib.json: exact round trip, independent read-back, and one clear error per kind of bad input."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from platypose.lifting.calibration import load_calibration, save_calibration
from platypose.lifting.errors import InputError


@pytest.fixture()
def pose2sim(data_dir: Path):
    return load_calibration(data_dir / "video/pose2sim-balancing/calib_pose2sim.toml")


def _native_text(camera: dict, **top) -> str:
    data = {"format": "platypose-calib", "version": 1, "units": "m", "world_up": "z", "cameras": [camera]}
    data.update(top)
    return json.dumps(data)


GOOD_CAMERA = {
    "name": "cam01",
    "size": [1080, 1920],
    "K": [[1500.0, 0, 960.0], [0, 1500.0, 540.0], [0, 0, 1]],
    "dist": [0.01, -0.02, 0.001, 0.0005, 0.003],
    "rvec": [0.1, -0.2, 0.3],
    "t": [0.5, 1.0, 4.0],
    "time_offset_s": 0.25,
}


def test_round_trip_is_exact(pose2sim, tmp_path):
    path = tmp_path / "calib.json"
    save_calibration(path, pose2sim)
    again = load_calibration(path)
    assert again.names == pose2sim.names
    for a, b in zip(pose2sim.cameras, again.cameras):
        for field in ("K", "dist", "R", "t"):
            assert np.array_equal(getattr(a, field), getattr(b, field))
        assert a.size == b.size and a.time_offset_s == b.time_offset_s
    assert again.meta == pose2sim.meta
    assert not list(tmp_path.glob(".*tmp*"))


def test_written_file_read_back_with_json(pose2sim, tmp_path):
    path = tmp_path / "calib.json"
    save_calibration(path, pose2sim)
    data = json.loads(path.read_text())
    assert (data["format"], data["version"], data["units"], data["world_up"]) == ("platypose-calib", 1, "m", "z")
    first = data["cameras"][0]
    assert first["name"] == "cam_01" and first["size"] == [1920, 1088]
    assert first["K"][0][0] == 1681.244873046875 and first["K"][1][2] == 948.137390140625
    assert first["dist"] == [-0.000721609375, 0.002187234375, 9.5e-06, 1.078125e-05, 0.0]
    R = cv2.Rodrigues(np.array([1.6882754799999993, 1.0483220499999997, -0.41955852000000016]))[0]
    assert np.allclose(first["R"], R, atol=1e-15)
    assert first["t"] == [0.3211048899999996, 0.9563320600000009, 2.8907130499999996]
    assert "assumed Z up" in data["meta"]["assumptions"][0]


@pytest.mark.parametrize("suffix", [".json", ".toml"])
def test_a_rational_lens_round_trips_and_projects_as_opencv(tmp_path, suffix):
    """OpenCV's rational model (k4 k5 k6, what a wide lens's camera from the scene carries) is written, read back
    exactly, and projects as cv2.projectPoints; a camera without it is written with 5 coefficients as before."""
    from platypose.lifting.calibration import Calibration
    from platypose.lifting.calibration.toml_format import write_toml
    from platypose.lifting.camera import Camera, project

    dist = np.array([-0.52, 0.31, 0.0, 0.0, -0.04, -0.11, 0.12, -0.01])
    wide = Camera("wide", (1080, 1920), [[900.0, 0, 960.0], [0, 900.0, 540.0], [0, 0, 1]], dist, t=[0.1, 0.2, 3.0])
    plain = Camera("plain", (1080, 1920), wide.K, [0.01, -0.02, 0.0, 0.0, 0.003], t=[0.5, 0.0, 3.0])
    path = tmp_path / f"calib{suffix}"
    if suffix == ".json":
        save_calibration(path, Calibration(cameras=[wide, plain], meta={"world_up": "z", "units": "m"}))
    else:
        write_toml(path, [wide, plain])
    again = load_calibration(path)
    assert np.array_equal(again.cameras[0].dist, dist)
    assert np.array_equal(again.cameras[1].dist, np.append(plain.dist[:5], [0.0, 0.0, 0.0]))
    if suffix == ".json":
        written = [camera["dist"] for camera in json.loads(path.read_text())["cameras"]]
    else:
        tomllib = pytest.importorskip("tomllib")  # the standard library's reader (Python 3.11+)
        written = [table["distortions"] for table in tomllib.loads(path.read_text()).values()]
    assert [len(values) for values in written] == [8, 5]  # read back by the standard library's readers
    points = np.random.default_rng(0).uniform([-2, -1, 2], [2, 1, 6], (50, 3))
    read = again.cameras[0]  # in the world the reader settled on (a .toml states none)
    expected = cv2.projectPoints(points, cv2.Rodrigues(read.R)[0], read.t, read.K, dist)[0][:, 0]
    assert np.allclose(project(points, read), expected, atol=1e-6)


def test_rvec_and_time_offset(tmp_path):
    path = tmp_path / "c.json"
    path.write_text(_native_text(GOOD_CAMERA))
    cam = load_calibration(path).cameras[0]
    assert np.allclose(cam.R, cv2.Rodrigues(np.array(GOOD_CAMERA["rvec"]))[0])
    assert cam.size == (1080, 1920) and cam.time_offset_s == 0.25


def test_native_file_in_mm_and_y_up_is_converted(tmp_path):
    path = tmp_path / "c.json"
    camera = dict(GOOD_CAMERA, t=[500.0, 1000.0, 4000.0])
    path.write_text(_native_text(camera, units="mm", world_up="y"))
    cam = load_calibration(path).cameras[0]
    reference_path = tmp_path / "m.json"
    reference_path.write_text(_native_text(GOOD_CAMERA))
    ref = load_calibration(reference_path).cameras[0]
    # same camera; world point (x, y, z) in the Y-up file is (x, -z, y) in ours
    y_up_point = np.array([0.3, 1.2, -0.4])
    ours = np.array([0.3, 0.4, 1.2])
    x_file = ref.R @ y_up_point + ref.t
    x_ours = cam.R @ ours + cam.t
    assert np.allclose(x_file, x_ours)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"K": [[1500.0, 0, 960.0], [0, 1500.0, 540.0]]}, "K has 6 values"),
        ({"R": np.diag([1.0, 1.0, 2.0]).tolist(), "rvec": None}, "not a rotation"),
        ({"R": np.diag([1.0, 1.0, -1.0]).tolist(), "rvec": None}, "not a rotation"),
        ({"t": None}, "missing t"),
        ({"rvec": None}, "missing R (or rvec)"),
        ({"size": [1080.5, 1920]}, "positive whole pixel"),
        ({"dist": [0.1, 0.2, 0.3]}, "3 coefficients"),
        ({"K": [[-5.0, 0, 960.0], [0, 1500.0, 540.0], [0, 0, 1]]}, "non-positive focal"),
        ({"R": np.eye(3).tolist()}, "both R and rvec"),
        ({"rotation": [0, 0, 0]}, "unknown fields ['rotation']"),
    ],
)
def test_bad_camera_fields(tmp_path, change, message):
    camera = {k: v for k, v in {**GOOD_CAMERA, **change}.items() if v is not None}
    path = tmp_path / "bad.json"
    path.write_text(_native_text(camera))
    with pytest.raises(InputError) as err:
        load_calibration(path)
    assert message in str(err.value) and str(path) in str(err.value)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("top", "message"),
    [
        ({"units": "furlong"}, "unknown units 'furlong'"),
        ({"world_up": "w"}, "unknown world up axis"),
        ({"version": 7}, "not a platypose-calib version 1"),
    ],
)
def test_bad_top_level(tmp_path, top, message):
    path = tmp_path / "bad.json"
    path.write_text(_native_text(GOOD_CAMERA, **top))
    with pytest.raises(InputError, match=message):
        load_calibration(path)


def test_missing_top_level_field_and_broken_json(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"format": "platypose-calib", "version": 1, "cameras": []}))
    with pytest.raises(InputError, match="missing field.*units, world_up"):
        load_calibration(path)
    path.write_text('{"format": "platypose-calib", "cameras": [')
    with pytest.raises(InputError, match="not valid JSON"):
        load_calibration(path)
    with pytest.raises(InputError, match="not found"):
        load_calibration(tmp_path / "absent.json")
