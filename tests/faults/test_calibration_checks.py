"""Calibration files and the cameras they give: bounded (a camera count, a file size, nesting too deep to parse,
numbers too large for a float, a time offset), importers' values out of range (focal lengths, sensor sizes,
distortion, cameras within millimetres of each other) each one line naming the problem, and the real files still
read; the cameras checked against the videos before any detection (another image size fails before anything is
read, an image too small to show a person is refused, a focal length no lens has is a warning; a calibration of one
camera given for another view or for four videos is one error).

The audit cases (marker ``audit``, run with ``pytest -m audit``) run ``platypose calib check`` and ``lift`` as the
real CLI; each run ends as due, unflagged (:mod:`audit_watch`, :mod:`audit_support`)."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from audit_support import CALIB as TAKE_CALIB
from audit_support import (
    FAST,
    KEYPOINT_TIMING,
    Case,
    Run,
    check_case,
    one_camera_calibration,
    openpose_copy,
    platypose,
    registry,
)
from audit_watch import CALIB, check

from platypose.lifting.calibration import load_calibration, save_calibration
from platypose.lifting.calibration.defaults import default_camera
from platypose.lifting.errors import InputError
from platypose.lifting.job_log import JobLog
from platypose.lifting.settings import TakeSettings
from platypose.pipeline import run_take, view_cameras

TAKE = TAKE_CALIB.parent
CALISCOPE = CALIB / "caliscope/camera_array.toml"
QUALISYS = CALIB / "pose2sim_demo.qca.txt"
FREEMOCAP = CALIB / "freemocap_test_data_camera_calibration.toml"


def _caliscope_with(path, count: int, source) -> None:
    """The real Caliscope camera_array.toml with its first camera repeated under ``count`` ids."""
    import tomllib

    first = tomllib.loads(source.read_text())["cameras"]["0"]
    body = "\n".join(f"{k} = {v!r}".replace("True", "true").replace("False", "false") for k, v in first.items())
    path.write_text("".join(f"[cameras.{i}]\n{body.replace('cam_id = 0', f'cam_id = {i}')}\n\n" for i in range(count)))


def test_calibration_camera_count_and_file_size_are_bounded(run_cli, data_dir, tmp_path) -> None:
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
    tree = ET.parse(CALIB / "pose2sim_demo.qca.txt")
    for transform in tree.getroot().iter("transform"):
        for axis in ("x", "y", "z"):
            transform.set(axis, repr(float(transform.get(axis)) * scale))
    path = tmp_path / f"scaled{scale:g}.qca.txt"
    tree.write(path)
    return path


def test_importers_refuse_absurd_values(run_cli, tmp_path) -> None:
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
    freemocap = (CALIB / "freemocap_test_data_camera_calibration.toml").read_text()
    path = tmp_path / "bigint.toml"
    path.write_text(
        re.sub(r"translation = \[[^\]]*\]", "translation = [ " + "9" * 400 + ", 0.0, 0.0,]", freemocap, count=1)
    )
    code, _, err = run_cli("calib", "check", str(path))
    assert code == 2 and "non-finite" in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("offset", [1e308, -1e6])
def test_calibration_time_offset_is_bounded(tmp_path: Path, offset: float) -> None:
    path = tmp_path / "c.json"
    save_calibration(path, load_calibration(TAKE_CALIB))
    content = json.loads(path.read_text())
    content["cameras"][1]["time_offset_s"] = offset
    path.write_text(json.dumps(content))
    expected = (
        f"c.json: camera 'cam_02' time_offset_s {offset:g} is out of range (a finite number of seconds, at most 86400"
    )
    with pytest.raises(InputError, match=re.escape(expected)):
        load_calibration(path)


def test_a_calibration_of_another_image_size_fails_before_detection(tmp_path: Path) -> None:
    path = tmp_path / "calib.json"
    save_calibration(path, load_calibration(TAKE_CALIB))
    content = json.loads(path.read_text())
    for camera in content["cameras"]:
        camera["size"] = [720, 1280]
    path.write_text(json.dumps(content))
    views = [(f"cam0{n}", TAKE / f"cam0{n}.mp4") for n in (1, 2)]
    read_calls: list[Path] = []

    def read(source: Path):
        read_calls.append(source)
        raise AssertionError("detection started")

    expected = f"{TAKE / 'cam01.mp4'}: calibration mismatch: calibration says 1280x720 px for camera cam_01, "
    with pytest.raises(InputError, match=re.escape(expected)):
        run_take(
            views=views,
            calibration=load_calibration(path),
            settings=TakeSettings(),
            read=read,
            prior=lambda: None,
            log=JobLog(),
            what="take",
        )
    assert read_calls == []


@pytest.mark.parametrize("size", [(1, 1), (1, 1920), (1088, 8)])
def test_an_image_too_small_for_a_person_is_refused(size) -> None:
    height, width = size
    with pytest.raises(InputError, match=rf"clip.mp4: the image is {width}x{height} pixels; a person's joints need"):
        view_cameras(None, [size], ["clip"], ["clip.mp4"], "clip.mp4", JobLog())
    camera = default_camera("clip", *size)
    with pytest.raises(InputError, match=rf"clip.mp4: the image is {width}x{height} pixels"):
        view_cameras([camera], [size], ["clip"], ["clip.mp4"], "clip.mp4", JobLog())


def test_a_focal_length_no_lens_has_is_a_warning() -> None:
    camera = default_camera("cam01", 1088, 1920)
    narrow = replace(camera, K=np.array([[50.0, 0, 960], [0, 50.0, 544], [0, 0, 1]]))
    log = JobLog()
    view_cameras([narrow], [(1088, 1920)], ["cam01"], ["cam01.mp4"], "take", log)
    assert log.warnings == [
        "camera cam01: focal length 50 px on a 1920 px wide image is a 174 degree field of view, wider than any lens "
        "the pinhole model fits: check the calibration's focal length (pixels, of this image size)"
    ]
    log = JobLog()
    view_cameras([camera], [(1088, 1920)], ["cam01"], ["cam01.mp4"], "take", log)
    assert log.warnings == []


def _caliscope_cameras(path: Path, count: int) -> Path:
    first = CALISCOPE.read_text().split("\n\n")[0]
    cameras = (
        first.replace("[cameras.0]", f"[cameras.{i}]").replace("cam_id =0", f"cam_id ={i}") for i in range(count)
    )
    path.write_text("\n\n".join(cameras))
    return path


@pytest.mark.audit
@pytest.mark.parametrize("count", [300, 20000])
def test_too_many_cameras(tmp_path: Path, count: int) -> None:
    calib = _caliscope_cameras(tmp_path / "many.toml", count)
    check(tmp_path / "case", ["calib", "check", calib], "error", ("many.toml", f"{count} cameras"))


@pytest.mark.audit
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


@pytest.mark.audit
def test_a_20_mib_file(tmp_path: Path) -> None:
    huge = tmp_path / "huge.toml"
    huge.write_bytes(CALISCOPE.read_bytes() + b"#" * (20 * 2**20))
    check(tmp_path / "case", ["calib", "check", huge], "error", ("huge.toml", "too large"))


@pytest.mark.audit
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


@pytest.mark.audit
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


@pytest.mark.audit
@pytest.mark.parametrize("scale", [1e-3, 0.0], ids=["metres", "one-point"])
def test_qualisys_cameras_too_close(tmp_path: Path, scale: float) -> None:
    tree = ET.parse(QUALISYS)
    for t in tree.getroot().iter("transform"):
        for axis in "xyz":
            t.set(axis, repr(float(t.get(axis)) * scale))
    tree.write(tmp_path / "calib.qca.txt")
    check(tmp_path / "case", ["calib", "check", tmp_path / "calib.qca.txt"], "error", ("calib.qca.txt", "within"))


@pytest.mark.audit
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


@pytest.mark.audit
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


@pytest.mark.audit
def test_h36m_cameras_need_a_subject(tmp_path: Path) -> None:
    check(
        tmp_path / "case", ["calib", "check", CALIB / "h36m_cameras.json"], "error", ("h36m_cameras.json", "--subject")
    )


@pytest.mark.audit
def test_a_newline_in_a_file_name_cannot_forge_an_error_line(tmp_path: Path) -> None:
    check(tmp_path / "case", ["calib", "check", "no\nerror: forged.toml"], "error", "no?error")


CASES: list[Case] = []
case = registry(CASES)


@case("calibration-time-offset-1e308")
def _(w: Path) -> Run:
    full = w / "calib.json"
    done = platypose(["calib", "convert", TAKE_CALIB, "--out", full], 60)
    assert done is not None and done.returncode == 0, done and done.stderr
    content = json.loads(full.read_text())
    content["cameras"][0]["time_offset_s"] = 1e308
    full.write_text(json.dumps(content))
    return Run(["calib", "check", full], says=("time_offset_s 1e+308 is out of range",))


@case("calibration-of-another-size-before-detection")
def _(w: Path) -> Run:
    full = w / "calib.json"
    done = platypose(["calib", "convert", TAKE_CALIB, "--out", full], 60)
    assert done is not None and done.returncode == 0, done and done.stderr
    content = json.loads(full.read_text())
    for camera in content["cameras"]:
        camera["size"] = [720, 1280]
    full.write_text(json.dumps(content))
    video = Path(TAKE_CALIB).parent / "cam01.mp4"
    args = ["lift", video, "--cams", full, *FAST, "--out", w / "out"]
    return Run(args, says=("calibration mismatch: calibration says 1280x720 px for camera cam_01",), timeout=60)


@case("one-camera-calibration-for-another-view")
def _(w: Path) -> Run:
    calib = one_camera_calibration(w, "cam_01")
    keypoints = openpose_copy(w / "kp", "cam02")
    args = ["lift", "--keypoints", keypoints, "--cams", calib, *KEYPOINT_TIMING, *FAST, "--out", w / "out"]
    return Run(args, says=("cam02_json", "calibration mismatch with", "only_cam_01.json"))


@case("one-camera-calibration-for-four-videos")
def _(w: Path) -> Run:
    calib = one_camera_calibration(w, "cam_01")
    take = w / "take"
    take.mkdir()
    for view in ("cam01", "cam02", "cam03", "cam04"):
        (take / f"{view}.mp4").symlink_to(TAKE / f"{view}.mp4")
    says = ("only_cam_01.json: the calibration has 1 camera (cam_01), you gave 4 videos", "cam04.mp4")
    return Run(["lift", take, "--cams", calib, "--out", w / "out", "-q"], says=says)


@pytest.mark.audit
@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
