"""The camera from the people in view: synthetic cameras of known pose seeing bundled mocap walkers, the lens's
focal length, and the pose measure that compares an estimate with a calibration."""

from __future__ import annotations

import math

import numpy as np
import pytest
from camera_scenes import scene_keypoints, walkers

from platypose.lifting.calibration import from_people as camera_estimate
from platypose.lifting.calibration.from_people import estimate_camera
from platypose.lifting.calibration.lens import METADATA, PRIOR, lens_focal
from platypose.lifting.calibration.one_view import fit_view
from platypose.lifting.calibration.pose_above_floor import pose_of, posed_camera

SCENES = [  # pitch, roll, focal (px), height (m), walkers (x, y, heading)
    (20.0, 8.0, 1400.0, 3.0, [(-1.5, 6.0, 30.0), (1.0, 9.0, -60.0), (0.5, 5.0, 120.0)]),
    (35.0, -12.0, 1000.0, 5.0, [(-2.0, 7.0, 90.0), (1.0, 10.0, -90.0), (0.0, 6.0, 180.0)]),
    (10.0, 3.0, 1800.0, 1.6, [(-1.0, 5.0, 10.0)]),  # one person only
]


@pytest.fixture
def quick(monkeypatch):
    """Fewer starts and bootstrap refits than a lift uses: the same fit, in a test's time."""
    monkeypatch.setattr(camera_estimate, "START_PITCHES_DEG", (10.0, 40.0))
    monkeypatch.setattr(camera_estimate, "START_ROLLS_DEG", (-15.0, 15.0))
    monkeypatch.setattr(camera_estimate, "BOOTSTRAP", 3)


@pytest.mark.parametrize("pitch, roll, focal, height, places", SCENES)
def test_a_known_lens_recovers_pitch_roll_and_height(quick, pitch, roll, focal, height, places):
    keypoints, _ = scene_keypoints(walkers(places, frames=60), pitch, roll, focal, height)
    found = estimate_camera(keypoints, np.arange(60) / 30.0, (1080, 1920), focal, METADATA, hold_focal=True)
    assert found is not None and found.problem is None
    assert abs(found.pitch_deg - pitch) < 2.0 and abs(found.roll_deg - roll) < 2.0  # the aim is 1
    assert abs(found.height_m / height - 1) < 0.12  # the walkers are 1.58 m tall, the scale assumes 1.70
    assert found.focal_px == pytest.approx(focal) and found.focal_source == METADATA
    assert 0 < found.sd["pitch_deg"] < 6.0 and found.sd["height_m"] > 0


def test_too_few_upright_frames_give_no_camera():
    keypoints, _ = scene_keypoints(walkers([(0.0, 5.0, 0.0)], frames=10), 15.0, 0.0, 1500.0, 2.0)
    camera, estimate, note = fit_view("v", keypoints, np.arange(10) / 30.0, (1080, 1920), {})
    assert camera is None and estimate is None and "fewer than 20 person-frames" in note


def test_the_lens_from_metadata_else_the_prior():
    focal, source = lens_focal({"com.apple.quicktime.camera.focal_length.35mm_equivalent": "26"}, (1080, 1920))
    assert source == METADATA and focal == pytest.approx(26 / math.hypot(36, 24) * math.hypot(1080, 1920))
    focal, source = lens_focal({"encoder": "Lavf58"}, (1920, 1088))
    assert source == PRIOR and focal == pytest.approx(960 / math.tan(math.radians(30)))


@pytest.mark.parametrize(
    "value", ["-26", "26e3", "\uff12\uff16", "\uff11\uff12\uff13", "26 or 52", "f/1.8 26", "7", "801", ""]
)
def test_a_lens_tag_is_read_only_as_a_whole_number_in_range(value: str):
    tags = {"com.apple.quicktime.camera.focal_length.35mm_equivalent": value}
    focal, source = lens_focal(tags, (1080, 1920))
    assert source == PRIOR and focal == pytest.approx(960 / math.tan(math.radians(30)))


@pytest.mark.parametrize("value, millimetres", [("26", 26.0), (" 26.5 ", 26.5), ("26 mm", 26.0), ("800", 800.0)])
def test_a_plain_lens_tag_is_read(value: str, millimetres: float):
    tags = {"FocalLengthIn35mmFormat": value}
    focal, source = lens_focal(tags, (1080, 1920))
    assert source == METADATA and focal == pytest.approx(millimetres / math.hypot(36, 24) * math.hypot(1080, 1920))


def test_pose_of_a_posed_camera_is_its_pose():
    camera = posed_camera("c", (1080, 1920), 1234.0, 22.5, -13.4, 1.9)
    assert pose_of(camera) == pytest.approx({"pitch_deg": 22.5, "roll_deg": -13.4, "height_m": 1.9, "focal_px": 1234.0})
    assert camera.R @ camera.R.T == pytest.approx(np.eye(3))
