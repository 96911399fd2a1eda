"""``export --video``: a video of another size than the result's camera (a smaller copy) is refused before
anything is written; thumbnails and the recording would otherwise be cut and drawn in the wrong place."""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from export_helpers import camera_facing, climb_joints, make_result

from platypose.exporters.export import export
from platypose.lifting.errors import InputError

DATA = Path(__file__).resolve().parents[2] / "data"


def video(path: Path, height: int, width: int) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (width, height))
    for n in range(3):
        writer.write(np.full((height, width, 3), 40 * n, np.uint8))
    writer.release()
    return path


@pytest.fixture(scope="module")
def result():
    joints, fps = climb_joints(DATA, 10)
    return make_result(joints, fps, 2, (camera_facing(joints),))


@pytest.mark.parametrize("formats", [["report"], ["rrd"]])
def test_a_smaller_copy_of_the_video_is_refused(result, tmp_path: Path, formats) -> None:
    height, width = result.cameras[0].size
    small = video(tmp_path / "small.mp4", height // 2, width // 2)
    expected = (
        f"small.mp4: the video is {width // 2}x{height // 2} pixels but camera cam01 of the result saw "
        f"{width}x{height}: not the video it was lifted from"
    )
    with pytest.raises(InputError, match=re.escape(expected)):
        export(result, tmp_path / "out", "take", formats, {"cam01": small})
    assert not (tmp_path / "out").exists()


def test_the_video_of_the_camera_s_size_is_taken(result, tmp_path: Path) -> None:
    height, width = result.cameras[0].size
    same = video(tmp_path / "same.mp4", height, width)
    written = export(result, tmp_path / "out", "take", ["report"], {"cam01": same})
    assert [p.name for p in written] == ["take_report.png"]
