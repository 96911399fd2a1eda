"""Intrinsics-only text, the no-calibration defaults, up-axis/unit conversion and view matching."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from platypose.lifting.calibration import load_calibration
from platypose.lifting.calibration.defaults import DIAGONAL_FOV_DEG, default_calibration, fov_prior_intrinsics
from platypose.lifting.calibration.matching import align_frames, gather_views, match_views, normalise_view_name
from platypose.lifting.calibration.world import unit_scale, up_rotation, up_vector
from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError

CALIB = Path(__file__).parents[2] / "data" / "calib"


def test_intrinsics_only_file():
    cal = load_calibration(CALIB / "intrinsics.txt")
    front, side = cal.cameras
    assert front.name == "front" and front.size == (1080, 1920)
    assert np.array_equal(front.K, [[1402.5, 0, 962.3], [0, 1401.8, 538.9], [0, 0, 1]])
    assert side.size == (720, 1280)
    notes = cal.meta["assumptions"]
    assert "camera side: image size not stated: assumed twice the principal point" in notes
    assert sum("no extrinsics" in n for n in notes) == 2


@pytest.mark.parametrize(
    "line", ["front 1400 1400 960", "1400 1400 960 540 1920", "cam -1400 1400 960 540", "a b c d e"]
)
def test_broken_intrinsics_line(tmp_path: Path, line: str):
    path = tmp_path / "k.txt"
    path.write_text(line + "\n")
    with pytest.raises(InputError, match="k.txt"):
        load_calibration(path)


def test_fov_prior_and_level_camera():
    K = fov_prior_intrinsics(1080, 1920)
    assert K[0, 0] == pytest.approx(math.hypot(1920, 1080)) and (K[0, 2], K[1, 2]) == (960.0, 540.0)
    diag_fov = 2 * math.degrees(math.atan(math.hypot(960, 540) / K[0, 0]))
    assert diag_fov == pytest.approx(DIAGONAL_FOV_DEG) == pytest.approx(53.13, abs=0.01)
    cal = default_calibration("clip", 1080, 1920, "clip.mp4")
    (cam,) = cal.cameras
    assert np.array_equal(cam.center, np.zeros(3))
    # world up (+z) is the camera's -y; the camera looks along world +y
    assert np.allclose(cam.R @ [0, 0, 1], [0, -1, 0]) and np.allclose(cam.R[2], [0, 1, 0])
    assert len(cal.meta["assumptions"]) == 2 and "53.1 degree" in cal.meta["assumptions"][0]


@pytest.mark.parametrize("axis", ["x", "-x", "y", "-y", "z", "-z"])
def test_up_rotation_takes_axis_to_z(axis: str):
    R = up_rotation(up_vector(axis, "f"))
    assert np.allclose(R @ up_vector(axis, "f"), [0, 0, 1])
    assert np.allclose(R @ R.T, np.eye(3)) and np.linalg.det(R) == pytest.approx(1.0)


def test_units():
    assert unit_scale("mm", "f") == 0.001 and unit_scale("CM", "f") == 0.01 and unit_scale("0.04", "f") == 0.04
    for bad in ("feet", "-2", "nan"):
        with pytest.raises(InputError, match="units"):
            unit_scale(bad, "f")
    with pytest.raises(InputError, match="world up axis"):
        up_vector("up", "f")


def test_match_views_by_normalised_name():
    assert {
        normalise_view_name(n) for n in ("cam_01", "cam01", "cam01_json", "cam01.mp4", "CAM-1", "x/cam01_json/")
    } == {"cam1"}
    cams = ["cam_01", "cam_02", "cam_03"]
    assert match_views(cams, ["cam03.mp4", "cam01.mp4", "cam02.mp4"]) == {
        "cam_01": "cam01.mp4",
        "cam_02": "cam02.mp4",
        "cam_03": "cam03.mp4",
    }
    assert match_views(["demo"], ["my_clip.mp4"]) == {"demo": "my_clip.mp4"}
    with pytest.raises(InputError, match="no view for camera.s. cam_03"):
        match_views(cams, ["cam01.mp4", "cam02.mp4"])
    assert match_views(cams, ["cam01.mp4"], allow_missing=True) == {"cam_01": "cam01.mp4"}
    with pytest.raises(InputError, match="view.s. cam09_json match no camera"):
        match_views(cams, ["cam01_json", "cam02_json", "cam03_json", "cam09_json"])
    with pytest.raises(InputError, match="both match the camera name 'cam1'"):
        match_views(cams, ["cam01.mp4", "cam_1.avi", "cam02.mp4", "cam03.mp4"])


def test_time_offsets_align_frames():
    assert align_frames(np.array([0.0, 0.1, 0.2, 0.3]), np.array([0.12, 0.21, 0.5]), 0.05).tolist() == [-1, 0, 1, -1]
    K = fov_prior_intrinsics(100, 100)
    cams = [Camera("a", (100, 100), K), Camera("b", (100, 100), K, time_offset_s=0.5)]
    kp_a = np.zeros((4, 1, 17, 3))
    kp_b = np.arange(1.0, 5.0)[:, None, None, None] * np.ones((4, 1, 17, 3))
    times = np.arange(4) / 2.0  # 2 fps; camera b started 0.5 s late, so its frame 0 is a's frame 1
    gathered = gather_views([kp_a, kp_b], [times, times], cams, 0.25)
    assert gathered[1][:, 0, 0, 0].tolist() == [0.0, 1.0, 2.0, 3.0]
    assert np.array_equal(gathered[0], kp_a)
