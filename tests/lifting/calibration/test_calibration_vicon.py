"""Vicon .xcp on a real Nexus 2.12 file (25 cameras, 5 Vue video cameras): values, projection, geometry, bad files."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from platypose.lifting.calibration import load_calibration
from platypose.lifting.calibration.vicon import vicon_camera
from platypose.lifting.camera import Camera, project
from platypose.lifting.errors import InputError

VICON = Path(__file__).parents[2] / "data/calib/vicon/opencap_testCalibration.xcp"
VUE_IDS = ("2111270", "2111275", "2121724", "2122194", "2141511")


def _elements() -> list[ET.Element]:
    return ET.parse(VICON).getroot().findall("Camera")


def _key(element: ET.Element) -> dict[str, np.ndarray]:
    """A camera's KeyFrame attributes as float arrays (the distortion model name dropped)."""
    attrs = dict(element.find("KeyFrames/KeyFrame").attrib)
    attrs["VICON_RADIAL2"] = attrs["VICON_RADIAL2"].split(" ", 1)[1]
    return {k: np.array(v.split(), dtype=float) for k, v in attrs.items() if k != "FRAME"}


def test_reads_video_cameras_in_metres():
    cal = load_calibration(VICON)
    assert cal.meta["format"] == "vicon-xcp" and cal.names == VUE_IDS
    assert all(c.size == (1080, 1920) for c in cal.cameras)
    assert "units mm scaled to metres (x0.001)" in cal.meta["conversions"]
    assert "2109510 (Vantage16V)" in cal.meta["assumptions"][0] and cal.meta["assumptions"][0].count("(Vantage") == 20
    heights = [c.center[2] for c in cal.cameras]
    assert all(0.5 < h < 3.5 for h in heights), heights  # Vue cameras on tripods and walls, metres


def test_projection_equals_opencv_from_raw_xml():
    """Pixels equal cv2.projectPoints with K, R, t taken straight from the XML (quaternion x y z w via scipy)."""
    cal = load_calibration(VICON)
    for element in _elements():
        if element.attrib["DEVICEID"] not in VUE_IDS:
            continue
        camera = cal.camera(element.attrib["DEVICEID"])
        key = _key(element)
        f, (cx, cy) = key["FOCAL_LENGTH"][0], key["PRINCIPAL_POINT"]
        K = np.array([[f, 0, cx], [0, f, cy], [0, 0, 1]])
        R = Rotation.from_quat(key["ORIENTATION"]).as_matrix()
        t = -R @ key["POSITION"] / 1000
        rng = np.random.default_rng(0)
        rays = np.c_[(rng.uniform([0, 0], [1920, 1080], (50, 2)) - [cx, cy]) / f, np.ones(50)]
        points = (rays * rng.uniform(1, 8, (50, 1)) - t) @ R
        expected = cv2.projectPoints(points, cv2.Rodrigues(R)[0], t, K, camera.dist)[0].reshape(-1, 2)
        assert np.abs(project(points, camera) - expected).max() < 1e-6


def test_distortion_fit_agrees_with_vicon_correction():
    """A recorded pixel, corrected with Vicon's polynomial and projected with our OpenCV k1 k2 k3, comes back to itself.

    Within 80% of the half-diagonal the largest difference is 0.4-1.7 px per camera (median 0.3-1.2 px); the
    corners, where Vicon's correction stretches the image by 34-64%, are off by up to 18 px (stated in meta).
    """
    cal = load_calibration(VICON)
    for element in _elements():
        if element.attrib["DEVICEID"] not in VUE_IDS:
            continue
        camera, key = cal.camera(element.attrib["DEVICEID"]), _key(element)
        cx, cy, k1, k2, k3 = key["VICON_RADIAL2"]
        u, v = np.meshgrid(np.linspace(0, 1920, 97), np.linspace(0, 1080, 55))
        recorded = np.stack([u.ravel(), v.ravel()], axis=-1)
        r2 = np.sum((recorded - [cx, cy]) ** 2, axis=-1, keepdims=True)
        ideal = [cx, cy] + (recorded - [cx, cy]) * (1 + k1 * r2 + k2 * r2**2 + k3 * r2**3)
        rays = np.c_[(ideal - camera.K[:2, 2]) / camera.K[0, 0], np.ones(len(ideal))]
        back = project((rays - camera.t) @ camera.R, camera)
        error = np.linalg.norm(back - recorded, axis=-1)
        inner = np.linalg.norm(recorded - camera.K[:2, 2], axis=-1) < 0.8 * np.hypot(960, 540)
        print(
            f"{camera.name}: median {np.median(error):.2f} px, within 80% of the half-diagonal at most "
            f"{error[inner].max():.2f} px, anywhere at most {error.max():.2f} px"
        )
        assert error[inner].max() < 2.0 and np.median(error) < 1.5, (camera.name, error[inner].max())
        assert error.max() < 20.0
        assert camera.dist[0] < 0  # a barrel lens in OpenCV's terms: Vicon corrects outwards


def test_cameras_look_into_one_volume():
    """Read as world-to-camera, the lab origin (set on the floor in the volume) is in 23 of 25 images, all 5 Vue.

    The other reading of the quaternion (camera-to-world) puts it in 2: the orientation convention is the one
    the cameras' own layout supports.
    """
    cameras = [vicon_camera(e, str(VICON))[0] for e in _elements()]

    def sees_origin(c: Camera) -> bool:
        u, v = project(np.zeros(3), c)
        return bool(c.t[2] > 0 and 0 <= u <= c.width and 0 <= v <= c.height)

    seen = [c.name for c in cameras if sees_origin(c)]
    transposed = [Camera(c.name, c.size, c.K, c.dist, c.R.T, -c.R.T @ c.center) for c in cameras]
    print(
        f"lab origin inside the image of {len(seen)} of {len(cameras)} cameras as read, "
        f"{sum(sees_origin(c) for c in transposed)} read camera-to-world"
    )
    assert len(cameras) == 25 and len(seen) == 23 and set(VUE_IDS) <= set(seen)
    assert all(c.R[1] @ [0, 0, 1] < -0.3 for c in cameras)  # image down is world down: upright cameras
    assert sum(sees_origin(c) for c in transposed) <= 2


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('FOCAL_LENGTH="1259.95621824408" ', "", "FOCAL_LENGTH is missing"),
        ('POSITION="5929.09138904118', 'POSITION="abc', "POSITION has a non-numeric value"),
        ('ORIENTATION="0.532674031345075', 'ORIENTATION="2.532674031345075', "not a unit quaternion"),
        ('VICON_RADIAL2="Vicon3Parameter 942.96', 'VICON_RADIAL2="Vicon5Parameter 942.96', "no VICON_RADIAL2"),
        ('PIXEL_ASPECT_RATIO="1" SENSOR="Vue 2"', 'PIXEL_ASPECT_RATIO="1.1" SENSOR="Vue 2"', "PIXEL_ASPECT_RATIO 1.1"),
        ('SENSOR_SIZE="1920 1080"', 'SENSOR_SIZE="1920"', "SENSOR_SIZE has 1 values"),
        ('SENSOR="Vue 2"', 'SENSOR="Vue 2" SKEW="0.5"', "SKEW 0.5"),
        ("</Cameras>", "", "not valid Vicon XML"),
        ("Vue_VIDEO", "Vue", "no video camera"),
        ('DEVICEID="2111275"', 'DEVICEID="2111270"', "duplicate camera names"),
    ],
)
def test_broken_files(tmp_path: Path, old: str, new: str, message: str):
    text = VICON.read_text()
    assert old in text
    path = tmp_path / VICON.name
    path.write_text(text.replace(old, new, 1 if "Vue_VIDEO" not in old else -1))
    with pytest.raises(InputError, match=message) as err:
        load_calibration(path)
    assert str(path) in str(err.value)


def test_moving_camera_refused(tmp_path: Path):
    text = VICON.read_text()
    first = text.index("<KeyFrame ", text.index('DEVICEID="2111270"'))
    end = text.index("/>", first) + 2
    path = tmp_path / "moving.xcp"
    path.write_text(text[:end] + text[first:end] + text[end:])
    with pytest.raises(InputError, match="2111270' has 2 KeyFrames"):
        load_calibration(path)


def test_cli_bad_file_exits_2(tmp_path: Path, run_cli):
    bad = tmp_path / "broken.xcp"
    bad.write_text(VICON.read_text().replace("</Cameras>", ""))
    code, _, stderr = run_cli("calib", "convert", str(bad), "--out", str(tmp_path / "c.json"))
    assert code == 2 and stderr.strip().count("\n") == 0 and str(bad) in stderr
    assert not (tmp_path / "c.json").exists()
