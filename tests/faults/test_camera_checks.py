"""The cameras are checked before any detection: a calibration whose image sizes are not the videos' (read from
their headers) fails before anything is read; an image too small to show a person is refused; a focal length no
lens has is a warning."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from platypose.lifting.calibration import load_calibration, save_calibration
from platypose.lifting.calibration.defaults import default_camera
from platypose.lifting.errors import InputError
from platypose.lifting.job_log import JobLog
from platypose.lifting.settings import TakeSettings
from platypose.pipeline import run_take, view_cameras

TAKE = Path(__file__).resolve().parents[2] / "data/video/pose2sim-balancing"


def test_a_calibration_of_another_image_size_fails_before_detection(tmp_path: Path) -> None:
    path = tmp_path / "calib.json"
    save_calibration(path, load_calibration(TAKE / "calib_pose2sim.toml"))
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
