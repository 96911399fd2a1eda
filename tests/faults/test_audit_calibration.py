"""Audit, calibration files: bounds (camera count, size, nesting), importers' values out of range, and the
real files still read; each ``platypose calib check`` ends as due, unflagged (:mod:`audit_watch`). Run with
``pytest -m audit``."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from audit_watch import CALIB, check

pytestmark = pytest.mark.audit

CALISCOPE = CALIB / "caliscope/camera_array.toml"
QUALISYS = CALIB / "pose2sim_demo.qca.txt"
FREEMOCAP = CALIB / "freemocap_test_data_camera_calibration.toml"


def _caliscope_cameras(path: Path, count: int) -> Path:
    first = CALISCOPE.read_text().split("\n\n")[0]
    cameras = (
        first.replace("[cameras.0]", f"[cameras.{i}]").replace("cam_id =0", f"cam_id ={i}") for i in range(count)
    )
    path.write_text("\n\n".join(cameras))
    return path


@pytest.mark.parametrize("count", [300, 20000])
def test_too_many_cameras(tmp_path: Path, count: int) -> None:
    calib = _caliscope_cameras(tmp_path / "many.toml", count)
    check(tmp_path / "case", ["calib", "check", calib], "error", ("many.toml", f"{count} cameras"))


@pytest.mark.parametrize(
    ("name", "text", "needle"),
    [
        ("deep.json", "[" * 100_000 + "]" * 100_000, "not valid JSON"),
        ("deep.toml", "a = " + "[" * 100_000 + "]" * 100_000, "not valid TOML"),
        ("deep-obj.json", '{"a":' * 50_000 + "1" + "}" * 50_000, "not valid JSON"),
    ],
)
def test_deeply_nested_files(tmp_path: Path, name: str, text: str, needle: str) -> None:
    (tmp_path / name).write_text(text)
    check(tmp_path / "case", ["calib", "check", tmp_path / name], "error", (name, needle))


def test_a_20_mib_file(tmp_path: Path) -> None:
    huge = tmp_path / "huge.toml"
    huge.write_bytes(CALISCOPE.read_bytes() + b"#" * (20 * 2**20))
    check(tmp_path / "case", ["calib", "check", huge], "error", ("huge.toml", "too large"))


@pytest.mark.parametrize(
    ("name", "attrs", "needle"),
    [
        ("focal-1e-300", {"FOCAL_LENGTH": "1e-300"}, "focal length"),
        ("focal-1e300", {"FOCAL_LENGTH": "1e300"}, "focal length"),
        ("focal-nan", {"FOCAL_LENGTH": "nan"}, "non-finite"),
        ("sensor-1e200", {"SENSOR_SIZE": "1e200 1e200"}, "pixel counts"),
        ("sensor-0", {"SENSOR_SIZE": "0 0"}, "pixel counts"),
        ("radial-1e10", {"VICON_RADIAL2": "Vicon3Parameter 960 540 1e10 1e10 1e10"}, "distortion"),
        ("radial-neg", {"VICON_RADIAL2": "Vicon3Parameter 960 540 -1e-3 0 0"}, "distortion"),
        ("position-1e300", {"POSITION": "1e300 0 0"}, "m from the origin; the --units look wrong"),
        ("quat-zero", {"ORIENTATION": "0 0 0 0"}, "quaternion"),
    ],
)
def test_vicon_values_out_of_range(tmp_path: Path, name: str, attrs: dict, needle: str) -> None:
    tree = ET.parse(CALIB / "vicon/opencap_testCalibration.xcp")
    cam = next(c for c in tree.getroot().findall("Camera") if "VIDEO" in c.attrib.get("TYPE", "").upper())
    key = cam.find("KeyFrames/KeyFrame")
    for k, v in attrs.items():
        (cam if k in cam.attrib else key).set(k, v)
    tree.write(tmp_path / f"{name}.xcp")
    check(tmp_path / "case", ["calib", "check", tmp_path / f"{name}.xcp"], "error", (f"{name}.xcp", needle))


@pytest.mark.parametrize(
    ("pattern", "repl", "needle"),
    [
        (r'focalLengthU="[^"]*"', 'focalLengthU="1e308"', "focal length"),
        (r'focalLengthU="[^"]*"', 'focalLengthU="0"', "focal length"),
        (r'radialDistortion1="[^"]*"', 'radialDistortion1="1e9"', "distortion"),
    ],
    ids=["focal-1e308", "focal-0", "dist-1e9"],
)
def test_qualisys_values_out_of_range(tmp_path: Path, pattern: str, repl: str, needle: str) -> None:
    path = tmp_path / "calib.qca.txt"
    path.write_text(re.sub(pattern, repl, QUALISYS.read_text()))
    check(tmp_path / "case", ["calib", "check", path], "error", ("calib.qca.txt", needle))


@pytest.mark.parametrize("scale", [1e-3, 0.0], ids=["metres", "one-point"])
def test_qualisys_cameras_too_close(tmp_path: Path, scale: float) -> None:
    tree = ET.parse(QUALISYS)
    for t in tree.getroot().iter("transform"):
        for axis in "xyz":
            t.set(axis, repr(float(t.get(axis)) * scale))
    tree.write(tmp_path / "calib.qca.txt")
    check(tmp_path / "case", ["calib", "check", tmp_path / "calib.qca.txt"], "error", ("calib.qca.txt", "within"))


@pytest.mark.parametrize(
    ("pattern", "repl", "needle", "count"),
    [
        (r"translation = \[[^\]]*\]", "translation = [ 0.0, 0.0, 0.0,]", "within", 0),
        (r"distortions = \[[^\]]*\]", "distortions = [ 1e9, 0.0, 0.0, 0.0, 0.0,]", "distortion", 1),
        (r"translation = \[[^\]]*\]", "translation = [ " + "9" * 400 + ", 0.0, 0.0,]", "non-finite", 1),
    ],
    ids=["one-point", "dist-1e9", "bigint"],
)
def test_freemocap_values_out_of_range(tmp_path: Path, pattern: str, repl: str, needle: str, count: int) -> None:
    path = tmp_path / "calib.toml"
    path.write_text(re.sub(pattern, repl, FREEMOCAP.read_text(), count=count))
    check(tmp_path / "case", ["calib", "check", path], "error", ("calib.toml", needle))


@pytest.mark.parametrize(
    "real",
    [
        "vicon/opencap_testCalibration.xcp",
        "pose2sim_demo.qca.txt",
        "freemocap_test_data_camera_calibration.toml",
        "caliscope/camera_array.toml",
        "anipose_mm.toml",
    ],
)
def test_real_files_still_read(tmp_path: Path, real: str) -> None:
    check(tmp_path / "case", ["calib", "check", CALIB / real], "ok")


def test_h36m_cameras_need_a_subject(tmp_path: Path) -> None:
    check(
        tmp_path / "case", ["calib", "check", CALIB / "h36m_cameras.json"], "error", ("h36m_cameras.json", "--subject")
    )


def test_a_newline_in_a_file_name_cannot_forge_an_error_line(tmp_path: Path) -> None:
    check(tmp_path / "case", ["calib", "check", "no\nerror: forged.toml"], "error", "no?error")
