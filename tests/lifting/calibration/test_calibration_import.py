"""Qualisys .qca.txt, Caliscope and FreeMoCap .toml on real files: values, projection, detection, bad files."""

from __future__ import annotations

import csv
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
import pytest

from platypose.lifting.calibration import load_calibration
from platypose.lifting.camera import project
from platypose.lifting.errors import InputError

CALIB = Path(__file__).parents[2] / "data/calib"
QUALISYS = CALIB / "pose2sim_demo.qca.txt"
CALISCOPE = CALIB / "caliscope/camera_array.toml"
FREEMOCAP = CALIB / "freemocap_test_data_camera_calibration.toml"
VICON = CALIB / "vicon/opencap_testCalibration.xcp"
POSE2SIM_TOML = "video/pose2sim-balancing/calib_pose2sim.toml"


def _points_in_front(camera, n: int = 100, seed: int = 0) -> np.ndarray:
    """World points (n, 3) 1-6 m in front of ``camera`` inside its image."""
    rng = np.random.default_rng(seed)
    h, w = camera.size
    rays = np.linalg.solve(camera.K, np.c_[rng.uniform([0, 0], [w, h], (n, 2)), np.ones(n)].T).T
    return (rays * rng.uniform(1, 6, (n, 1)) - camera.t) @ camera.R


def test_qualisys_matches_pose2sim_conversion(data_dir: Path):
    """The Pose2Sim demo's .qca.txt gives the cameras of the toml Pose2Sim converted from it (R, t, K exactly)."""
    cal = load_calibration(QUALISYS)
    reference = load_calibration(data_dir / POSE2SIM_TOML)
    assert cal.names == ("cam01", "cam02", "cam03", "cam04") and cal.meta["format"] == "qualisys-qca"
    assert "units mm scaled to metres (x0.001)" in cal.meta["conversions"]
    for ours, ref in zip(cal.cameras, reference.cameras):
        assert ours.size == ref.size == (1920, 1088)
        assert np.allclose(ours.R, ref.R, atol=1e-9) and np.allclose(ours.t, ref.t, atol=1e-9)
        assert np.allclose(ours.K, ref.K, atol=1e-9)
        # Pose2Sim divides Qualisys distortion by 64; we read it as OpenCV's (docs/calibration.md)
        assert np.allclose(ours.dist[:4], ref.dist[:4] * 64, rtol=1e-4)


def test_qualisys_projection_equals_opencv_from_raw_xml():
    """Pixels equal cv2.projectPoints with parameters taken straight from the XML attributes."""
    cal = load_calibration(QUALISYS)
    for element, camera in zip(ET.parse(QUALISYS).getroot().iter("camera"), cal.cameras):
        a = {k: float(v) for k, v in element.find("intrinsic").attrib.items()}
        tr = {k: float(v) for k, v in element.find("transform").attrib.items()}
        K = np.array(
            [
                [a["focalLengthU"] / 64, 0, a["centerPointU"] / 64],
                [0, a["focalLengthV"] / 64, a["centerPointV"] / 64],
                [0, 0, 1],
            ]
        )
        dist = np.array(
            [
                a["radialDistortion1"],
                a["radialDistortion2"],
                a["tangentalDistortion1"],
                a["tangentalDistortion2"],
                a["radialDistortion3"],
            ]
        )
        rows = np.array([[tr[f"r{i}{j}"] for j in (1, 2, 3)] for i in (1, 2, 3)])
        R = np.diag([1.0, -1.0, -1.0]) @ rows  # Qualisys cameras look along -z with y up
        centre = np.array([tr["x"], tr["y"], tr["z"]]) / 1000
        points = _points_in_front(camera)
        expected = cv2.projectPoints(points, cv2.Rodrigues(R)[0], -R @ centre, K, dist)[0].reshape(-1, 2)
        assert np.abs(project(points, camera) - expected).max() < 1e-6


@pytest.mark.parametrize(
    ("source", "old", "new", "message"),
    [
        (QUALISYS, 'focalLengthU="107599.671875" ', "", "intrinsic is missing focalLengthU"),
        (QUALISYS, 'r11="0.5536380477336265"', 'r11="2.0"', "transform is not a rotation"),
        (QUALISYS, 'viewrotation="0"', 'viewrotation="90"', "viewrotation 90"),
        (QUALISYS, 'x="1460.2323709212087"', 'x="abc"', "non-numeric"),
        (QUALISYS, "</cameras>", "", "not valid Qualisys XML"),
        (QUALISYS, 'serial="cam02"', 'serial="cam01"', "duplicate camera names"),
        (CALISCOPE, "size = [1280, 720]", "size = [1280]", "size has 1 values"),
        (CALISCOPE, "[0.0, 0.0, 1.0]]", "[0.0, 0.0, 2.0]]", "not a pinhole camera matrix"),
        (CALISCOPE, "ignore = false", "ignore = false\nfisheye = true", "fisheye"),
        (CALISCOPE, "[cameras.1]", "[cameras.1", "not valid TOML"),
    ],
)
def test_broken_files(tmp_path: Path, source: Path, old: str, new: str, message: str):
    text = source.read_text()
    assert old in text
    path = tmp_path / source.name
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(InputError, match=message) as err:
        load_calibration(path)
    assert str(path) in str(err.value)


def test_qualisys_skips_marker_and_inactive_cameras(tmp_path: Path):
    text = QUALISYS.read_text().replace(
        'model="none" point-count="999999999" serial="cam02"', 'model="Miqus M3" point-count="9" serial="cam02"'
    )
    path = tmp_path / "mixed.qca.txt"
    path.write_text(text.replace('active="1" avg-residual="0.450323"', 'active="0" avg-residual="0.450323"'))
    cal = load_calibration(path)
    assert cal.names == ("cam01", "cam04")
    assert "camera cam02: marker camera (Miqus M3), skipped" in cal.meta["assumptions"]
    assert "camera cam03: inactive, skipped" in cal.meta["assumptions"]


def test_caliscope_reprojects_its_own_charuco_points():
    """Caliscope's triangulated board corners project onto its observed 2D corners within 3 px (median 0.7-2.1 px per camera)."""
    cal = load_calibration(CALISCOPE)
    assert cal.names == ("cam_0", "cam_1", "cam_2", "cam_3") and cal.meta["format"] == "caliscope-toml"
    assert cal.cameras[0].size == (720, 1280) and cal.meta["conversions"] == []
    with (CALISCOPE.parent / "xyz_CHARUCO_subset.csv").open() as f:
        xyz = {
            (r["sync_index"], r["keypoint_id"]): [float(r[k]) for k in ("x_coord", "y_coord", "z_coord")]
            for r in csv.DictReader(f)
        }
    errors: dict[str, list[float]] = {}
    with (CALISCOPE.parent / "xy_CHARUCO_subset.csv").open() as f:
        for r in csv.DictReader(f):
            key = (r["sync_index"], r["keypoint_id"])
            if key in xyz:
                camera = cal.camera(f"cam_{r['cam_id']}")
                observed = [float(r["img_loc_x"]), float(r["img_loc_y"])]
                errors.setdefault(camera.name, []).append(
                    float(np.linalg.norm(project(np.array(xyz[key]), camera) - observed))
                )
    assert set(errors) == set(cal.names) and sum(len(e) for e in errors.values()) >= 90
    assert all(np.median(e) < 3.0 for e in errors.values()), {n: np.median(e) for n, e in errors.items()}


def _toml(path: Path) -> dict:
    if sys.version_info >= (3, 11):
        import tomllib
    else:
        import tomli as tomllib
    return tomllib.loads(path.read_text())


def test_caliscope_projection_equals_opencv():
    cal = load_calibration(CALISCOPE)
    for table, camera in zip(_toml(CALISCOPE)["cameras"].values(), cal.cameras):
        points = _points_in_front(camera)
        rvec = cv2.Rodrigues(np.array(table["rotation"]))[0]
        expected = cv2.projectPoints(
            points, rvec, np.array(table["translation"]), np.array(table["matrix"]), np.array(table["distortions"])
        )[0]
        assert np.abs(project(points, camera) - expected.reshape(-1, 2)).max() < 1e-6


def test_freemocap_units_and_up_detected():
    """FreeMoCap's test calibration: millimetres and camera 0's frame (y down) are detected and converted."""
    cal = load_calibration(FREEMOCAP)
    assert cal.meta["format"] == "freemocap-toml" and len(cal.cameras) == 3
    notes = " ".join(cal.meta["assumptions"])
    assert "millimetres detected" in notes and "-y detected from the cameras' image-up" in notes
    assert "units mm scaled to metres (x0.001)" in cal.meta["conversions"]
    assert "world up axis -y rotated to +z" in cal.meta["conversions"]
    assert cal.cameras[0].size == (1280, 720)  # portrait phone video: [width, height] = [720, 1280]
    centres = np.stack([c.center for c in cal.cameras])
    assert 1.0 < np.linalg.norm(centres[1] - centres[0]) < 5.0  # 2.7 m apart, not 2,700 m
    # the cameras are now upright in a Z-up world: each image's up points up
    assert all(-c.R[1] @ [0, 0, 1] > 0.8 for c in cal.cameras)
    # and their optical axes meet in front of all of them, 1-5 m away (they film one person)
    A, b = np.zeros((3, 3)), np.zeros(3)
    for c in cal.cameras:
        P = np.eye(3) - np.outer(c.R[2], c.R[2])
        A, b = A + P, b + P @ c.center
    meeting = np.linalg.solve(A, b)
    assert all(1.0 < (meeting - c.center) @ c.R[2] < 5.0 for c in cal.cameras)


def test_freemocap_projection_equals_opencv_in_file_units():
    """A point in the file's millimetre, camera-0 frame lands on the same pixel as cv2.projectPoints says."""
    cal = load_calibration(FREEMOCAP)
    tables = [t for k, t in _toml(FREEMOCAP).items() if k.startswith("cam_")]
    to_ours = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])  # X_ours = to_ours @ X_file (-y up -> +z up)
    for table, camera in zip(tables, cal.cameras):
        points_m = _points_in_front(camera)
        points_file = points_m @ to_ours * 1000  # back to the file's frame and units
        expected = cv2.projectPoints(
            points_file,
            np.array(table["rotation"]),
            np.array(table["translation"]),
            np.array(table["matrix"]),
            np.array(table["distortions"]),
        )[0]
        assert np.abs(project(points_m, camera) - expected.reshape(-1, 2)).max() < 1e-6


def test_overrides_beat_detection():
    cal = load_calibration(FREEMOCAP, units="mm", world_up="z")
    assert "world up axis" not in " ".join(cal.meta["conversions"])
    with pytest.raises(InputError, match="units look wrong"):
        load_calibration(FREEMOCAP, units="m")


def test_caliscope_ignored_camera_left_out(tmp_path: Path):
    path = tmp_path / "camera_array.toml"
    path.write_text(CALISCOPE.read_text().replace("ignore = false", "ignore = true", 1))
    assert load_calibration(path).names == ("cam_1", "cam_2", "cam_3")


@pytest.mark.parametrize("source", [QUALISYS, CALISCOPE, FREEMOCAP, VICON])
def test_cli_convert_round_trip(tmp_path: Path, run_cli, source: Path):
    """``calib convert`` writes calib.json; reading it back gives the same cameras, and ``calib check`` reads it."""
    out = tmp_path / "calib.json"
    code, stdout, _ = run_cli("calib", "convert", str(source), "--out", str(out))
    assert code == 0 and f"wrote {out}" in stdout
    direct, native = load_calibration(source), load_calibration(out)
    assert native.names == direct.names and native.meta["assumptions"] == direct.meta["assumptions"]
    for a, b in zip(direct.cameras, native.cameras):
        assert np.array_equal(a.R, b.R) and np.array_equal(a.t, b.t) and np.array_equal(a.K, b.K)
    code, stdout, _ = run_cli("calib", "check", str(source))
    assert code == 0 and f"format {direct.meta['format']}" in stdout
