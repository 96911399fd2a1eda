"""Calibration files are bounded: a camera count and a file size, importers' values out of range (focal lengths,
sensor sizes, distortion, cameras within millimetres of each other), nesting too deep to parse and numbers too large
for a float; each is one line naming the problem, and the real files still load."""

from __future__ import annotations

from pathlib import Path

import pytest

from platypose.lifting.errors import InputError

CALIB = Path(__file__).parents[1] / "data/calib"


def _caliscope_with(path, count: int, source) -> None:
    """The real Caliscope camera_array.toml with its first camera repeated under ``count`` ids."""
    import tomllib

    first = tomllib.loads(source.read_text())["cameras"]["0"]
    body = "\n".join(f"{k} = {v!r}".replace("True", "true").replace("False", "false") for k, v in first.items())
    path.write_text("".join(f"[cameras.{i}]\n{body.replace('cam_id = 0', f'cam_id = {i}')}\n\n" for i in range(count)))


def test_calibration_camera_count_and_file_size_are_bounded(run_cli, data_dir, tmp_path) -> None:
    from platypose.lifting.calibration import load_calibration

    source = CALIB / "caliscope/camera_array.toml"
    many = tmp_path / "many.toml"
    _caliscope_with(many, 2000, source)
    code, _, err = run_cli("calib", "check", str(many))
    assert code == 2 and "2000 cameras; at most 256" in err and len(err.strip().splitlines()) == 1, err
    huge = tmp_path / "huge.toml"
    huge.write_bytes(source.read_bytes() + b"#" * (17 * 2**20))
    with pytest.raises(InputError, match="too large for a calibration file"):
        load_calibration(huge)


def _vicon_with(tmp_path, name: str, **attributes) -> Path:
    """The real Vicon .xcp with the first video camera's attributes (its own or its KeyFrame's) replaced."""
    import xml.etree.ElementTree as ET

    tree = ET.parse(CALIB / "vicon/opencap_testCalibration.xcp")
    camera = next(c for c in tree.getroot().findall("Camera") if "VIDEO" in c.attrib.get("TYPE", "").upper())
    key = camera.find("KeyFrames/KeyFrame")
    for attribute, value in attributes.items():
        (camera if attribute in camera.attrib else key).set(attribute, value)
    path = tmp_path / f"{name}.xcp"
    tree.write(path)
    return path


def _qualisys_scaled(tmp_path, scale: float) -> Path:
    """The real Qualisys file with every camera position multiplied by ``scale`` (1/1000: a file in metres)."""
    import xml.etree.ElementTree as ET

    tree = ET.parse(CALIB / "pose2sim_demo.qca.txt")
    for transform in tree.getroot().iter("transform"):
        for axis in ("x", "y", "z"):
            transform.set(axis, repr(float(transform.get(axis)) * scale))
    path = tmp_path / f"scaled{scale:g}.qca.txt"
    tree.write(path)
    return path


def test_importers_refuse_absurd_values(run_cli, tmp_path) -> None:
    import re

    from platypose.lifting.calibration import load_calibration

    cases = [
        (_vicon_with(tmp_path, "tiny_focal", FOCAL_LENGTH="1e-300"), "focal length"),
        (_vicon_with(tmp_path, "huge_sensor", SENSOR_SIZE="1e200 1e200"), "pixel counts up to"),
        (_vicon_with(tmp_path, "huge_radial", VICON_RADIAL2="Vicon3Parameter 960 540 1e10 1e10 1e10"), "distortion"),
        (_qualisys_scaled(tmp_path, 1e-3), "within"),
        (_qualisys_scaled(tmp_path, 0.0), "within 0.0 mm"),
    ]
    qualisys = (CALIB / "pose2sim_demo.qca.txt").read_text()
    huge = tmp_path / "huge_focal.qca.txt"
    huge.write_text(re.sub(r'focalLengthU="[^"]*"', 'focalLengthU="1e308"', qualisys, count=1))
    cases.append((huge, "focal length"))
    freemocap = (CALIB / "freemocap_test_data_camera_calibration.toml").read_text()
    one_point = tmp_path / "one_point.toml"
    one_point.write_text(re.sub(r"translation = \[[^\]]*\]", "translation = [ 0.0, 0.0, 0.0,]", freemocap))
    cases.append((one_point, "within 0.0 mm"))
    distorted = tmp_path / "distorted.toml"
    distorted.write_text(re.sub(r"distortions = \[[^\]]*\]", "distortions = [ 1e9, 0.0, 0.0, 0.0, 0.0,]", freemocap))
    cases.append((distorted, "distortion"))
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    cases.append((deep, "not valid JSON"))
    deep_toml = tmp_path / "deep.toml"
    deep_toml.write_text("a = " + "[" * 100_000 + "]" * 100_000)
    cases.append((deep_toml, "not valid TOML"))
    for path, needle in cases:
        with pytest.raises(InputError, match=re.escape(needle)):
            load_calibration(path)
        code, _, err = run_cli("calib", "check", str(path))
        assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, (path.name, err)
    for real in (
        "vicon/opencap_testCalibration.xcp",
        "pose2sim_demo.qca.txt",
        "freemocap_test_data_camera_calibration.toml",
    ):
        assert load_calibration(CALIB / real).cameras  # the real files still load


def test_calibration_numbers_too_large_for_a_float(run_cli, tmp_path) -> None:
    import re

    freemocap = (CALIB / "freemocap_test_data_camera_calibration.toml").read_text()
    path = tmp_path / "bigint.toml"
    path.write_text(
        re.sub(r"translation = \[[^\]]*\]", "translation = [ " + "9" * 400 + ", 0.0, 0.0,]", freemocap, count=1)
    )
    code, _, err = run_cli("calib", "check", str(path))
    assert code == 2 and "non-finite" in err and len(err.strip().splitlines()) == 1, err
