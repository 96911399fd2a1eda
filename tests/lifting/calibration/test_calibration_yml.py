"""OpenCV FileStorage .yml: EasyMocap pairs (written by cv2.FileStorage and by hand), single-camera files, bad files."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from platypose.lifting.calibration import load_calibration
from platypose.lifting.camera import project
from platypose.lifting.errors import InputError

CALIB = Path(__file__).parents[2] / "data" / "calib"


def _fs_matrix(path: Path, key: str) -> np.ndarray:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    return fs.getNode(key).mat()


@pytest.mark.parametrize("target", ["easymocap_cv2", "easymocap_cv2/intri.yml", "easymocap_cv2/extri.yml"])
def test_easymocap_pair_written_by_opencv(data_dir: Path, target: str):
    cal = load_calibration(CALIB / target)
    reference = load_calibration(data_dir / "video/pose2sim-balancing/calib_pose2sim.toml")
    assert cal.names == ("01", "02", "03", "04")
    points = np.random.default_rng(1).uniform([-1, -1, 0], [1, 1, 2], size=(50, 3))
    for ours, ref in zip(cal.cameras, reference.cameras):
        assert ours.size == ref.size == (1920, 1088)
        assert np.allclose(ours.K, ref.K) and np.allclose(ours.dist, ref.dist)
        assert np.allclose(project(points, ours), project(points, ref), atol=1e-9)
    assert cal.meta["format"] == "easymocap-yml"


def test_easymocap_projection_equals_opencv():
    cal = load_calibration(CALIB / "easymocap_cv2")
    intri, extri = CALIB / "easymocap_cv2/intri.yml", CALIB / "easymocap_cv2/extri.yml"
    points = np.random.default_rng(2).uniform([-1, -1, 0], [1, 1, 2], size=(50, 3))
    for cam in cal.cameras:
        n = cam.name
        expected = cv2.projectPoints(
            points,
            _fs_matrix(extri, f"R_{n}"),
            _fs_matrix(extri, f"T_{n}"),
            _fs_matrix(intri, f"K_{n}"),
            _fs_matrix(intri, f"dist_{n}"),
        )[0].reshape(-1, 2)
        assert np.abs(project(points, cam) - expected).max() < 1e-6


def test_hand_written_easymocap_pair(data_dir: Path):
    cal = load_calibration(CALIB / "easymocap_hand")
    reference = load_calibration(data_dir / "video/pose2sim-balancing/calib_pose2sim.toml")
    assert cal.names == ("03", "04")
    points = np.random.default_rng(3).uniform([-1, -1, 0], [1, 1, 2], size=(50, 3))
    for ours, ref in zip(cal.cameras, reference.cameras[2:]):
        assert np.allclose(project(points, ours), project(points, ref), atol=1e-9)
    # no H_/W_ in the file: size from the principal point, said in meta
    assert cal.cameras[0].size == (1910, 1026)
    assert any("twice the principal point" in note for note in cal.meta["assumptions"])


def test_opencv_single_camera_file():
    cal = load_calibration(CALIB / "opencv_single.yml")
    (cam,) = cal.cameras
    assert cam.name == "opencv_single" and cam.size == (720, 1280)
    assert cam.K[0, 0] == pytest.approx(912.36427612304688) and cam.dist[4] == pytest.approx(0.12197203934192657)
    assert np.array_equal(cam.t, np.zeros(3)) and any("no extrinsics" in n for n in cal.meta["assumptions"])
    # level camera at the origin looking along +y: a point 5 m ahead and 1 m up is up in the image
    assert np.allclose(cam.R @ np.array([0.0, 5.0, 1.0]) + cam.t, [0.0, -1.0, 5.0])
    assert project(np.array([0.0, 5.0, 1.0]), cam)[1] < cam.K[1, 2]


def test_broken_yml_files(tmp_path: Path):
    garbage = tmp_path / "garbage.yml"
    garbage.write_text("%YAML:1.0\n---\ncamera_matrix: !!opencv-matrix\n   rows: 3\n  cols: [\n")
    with pytest.raises(InputError, match="garbage.yml"):
        load_calibration(garbage)
    empty = tmp_path / "empty.yml"
    empty.write_text("%YAML:1.0\n---\nimage_width: 640\n")
    with pytest.raises(InputError, match="no camera_matrix"):
        load_calibration(empty)
    pair = tmp_path / "pair"
    pair.mkdir()
    text = (CALIB / "easymocap_hand/intri.yml").read_text()
    (pair / "intri.yml").write_text(text.replace("K_04:", "Kx_04:"))
    with pytest.raises(InputError, match="missing K_04"):
        load_calibration(pair)
    (pair / "intri.yml").write_text(text)
    extri = (CALIB / "easymocap_hand/extri.yml").read_text()
    (pair / "extri.yml").write_text(extri.replace("T_04:", "Tx_04:"))
    with pytest.raises(InputError, match="needs Rot_04 .or R_04. and T_04"):
        load_calibration(pair)
