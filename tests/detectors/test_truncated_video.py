"""A truncated video (the container states more frames than decode) is reported, not silently ok."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
from media_helpers import truncated_copy

from platypose.detectors.sources.video import decoding_shortfall, iter_frames, video_info
from platypose.detectors.video_detection import detect_video

CAM01 = "video/pose2sim-balancing/cam01.mp4"


class _OnePerson:
    """A stand-in detector: one fixed person per frame in COCO-17 layout (the test is about frame counting)."""

    name = "fixed"
    layout = "coco17"

    def __call__(self, frame: np.ndarray) -> np.ndarray:
        h, w = frame.shape[:2]
        points = np.column_stack([np.linspace(0.4, 0.6, 17) * w, np.linspace(0.2, 0.9, 17) * h, np.full(17, 0.9)])
        return points[None].astype(np.float32)


def test_truncated_video_gets_a_note(data_dir, tmp_path):
    video = truncated_copy(data_dir / CAM01, tmp_path / "cam01.mp4", 0.6)
    info = video_info(video)
    decoded = sum(1 for _ in iter_frames(video))
    assert info.frame_count == 100 and 20 < decoded < 90  # the container still says 100
    tracks = detect_video(video, _OnePerson())
    assert tracks.num_frames == decoded
    (note,) = tracks.notes
    assert f"states 100 frames but only {decoded} could be decoded" in note and "cam01.mp4" in note


def test_whole_video_and_max_frames_get_no_note(data_dir):
    video = data_dir / CAM01
    assert detect_video(video, _OnePerson(), stride=7).notes == ()
    assert detect_video(video, _OnePerson(), max_frames=5).notes == ()
    info = video_info(video)
    assert decoding_shortfall(video, info, np.arange(0, 99, 3), stride=3) is None


def test_detect_command_warns_about_the_truncated_video(data_dir, tmp_path):
    video = truncated_copy(data_dir / CAM01, tmp_path / "cam01.mp4", 0.6)
    args = ["detect", str(video), "--out", str(tmp_path / "out"), "--stride", "10", "-q", "--threads", "1"]
    env = {k: v for k, v in os.environ.items() if not k.startswith("OPENCV_")}
    done = subprocess.run([sys.executable, "-m", "platypose", *args], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: ") and "states 100 frames but only" in lines[0]
