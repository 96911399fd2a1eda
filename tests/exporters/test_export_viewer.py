"""The recording opens in rerun's own viewer (headless, software Vulkan) with the default layout drawn.

Skipped where the machine has no Vulkan driver (the viewer cannot start) or no
FFmpeg (rerun's native viewer decodes H.264 with it).
"""

from __future__ import annotations

import os
import shutil
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from export_helpers import two_person_result

from platypose.exporters.rrd import person_colour, write_rrd

VENV_BIN = str(Path(sys.executable).parent)
HAS_VULKAN = any(Path(d).is_dir() and any(Path(d).iterdir()) for d in ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d"))
pytestmark = pytest.mark.skipif(
    not HAS_VULKAN or shutil.which("ffmpeg") is None, reason="needs a Vulkan driver (e.g. lavapipe) and ffmpeg"
)


def _share_of_vivid(png: bytes) -> float:
    """Share of saturated, bright pixels (skeletons; the grid and background are grey or dark)."""
    hsv = cv2.cvtColor(cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR), cv2.COLOR_BGR2HSV)
    return float(((hsv[..., 1] > 80) & (hsv[..., 2] > 80)).mean())


def _share_of_colour(png: bytes, rgba: tuple[int, int, int, int], tolerance: int = 40) -> float:
    """Share of pixels within ``tolerance`` of a colour in a PNG screenshot."""
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)[..., ::-1].astype(int)
    return float((np.abs(image - np.array(rgba[:3])).max(axis=-1) < tolerance).mean())


def test_recording_opens_with_video_skeletons_and_plots(data_dir, tmp_path, monkeypatch):
    from rerun.experimental import ViewerClient

    video = data_dir / "video/pose2sim-balancing/cam01.mp4"
    path = write_rrd(two_person_result(data_dir), tmp_path / "clip.rrd", "clip", {"cam01": video})
    monkeypatch.setenv("PATH", VENV_BIN + os.pathsep + os.environ["PATH"])
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    with ViewerClient.spawn(headless=True, port=9897, hide_welcome_screen=True) as viewer:
        try:
            viewer.open(str(path))
            time.sleep(3)
            state = viewer.get_state()
            assert state.recordings[0].current_timeline == "time"
            assert state.recordings[0].current_time == 0  # opens at the first frame
            viewer.set_time("time", duration=0.1, play_state="paused")
            time.sleep(2)
            views = {(v.view_class, v.origin): v for v in viewer.get_state().views}
            assert set(views) == {
                ("3D", "/world"),
                ("2D", "/world/cameras/cam01"),
                ("2D", "/world/cameras/cam02"),
                ("TimeSeries", "/plots/energy/p0"),
                ("TimeSeries", "/plots/energy/p7"),
                ("TimeSeries", "/plots/spread/p0"),
                ("TimeSeries", "/plots/spread/p7"),
                ("TextDocument", "/quality"),
            }
            assert all(v.visible and not v.reports for v in views.values())
            shot_3d = viewer.take_screenshot(views[("3D", "/world")].view_id)
            shot_cam = viewer.take_screenshot(views[("2D", "/world/cameras/cam01")].view_id)
        finally:
            viewer.quit()
    assert _share_of_vivid(shot_3d) > 0.002  # skeletons are drawn
    cam = cv2.imdecode(np.frombuffer(shot_cam, np.uint8), cv2.IMREAD_COLOR)
    assert cam.std() > 20  # video pixels, not an empty view
    assert _share_of_colour(shot_cam, person_colour(0)) > 0.0005  # 2D keypoints over it, in person 0's colour
    for slot in (0, 1):  # each person drawn in its own colour (lit, so loosely)
        assert _share_of_colour(shot_3d, person_colour(slot)) > 0.0001
