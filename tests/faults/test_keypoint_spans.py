"""Per-frame keypoint files numbered far apart with many people each are refused before the dense tracks
(frames x persons) are allocated: 63 OpenPose files 100,000 frames apart with 100 people took 53 GiB."""

from __future__ import annotations

import json
import resource
from pathlib import Path

import pytest

from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.lifting.errors import InputError

REAL = sorted(
    (Path(__file__).resolve().parents[2] / "data/video/pose2sim-balancing/openpose-body25b/cam01_json").glob("*.json")
)[0]


def crowd(folder: Path, files: int, people: int) -> Path:
    """``files`` OpenPose files 100,000 frames apart, each with ``people`` copies of a real person."""
    content = json.loads(REAL.read_text())
    content["people"] = content["people"][:1] * people
    folder.mkdir()
    for n in range(files):
        (folder / f"cam01.{n * 100_000:09d}.json").write_text(json.dumps(content))
    return folder


def read(folder: Path) -> None:
    read_openpose_folder(folder, fps=60.0, image_size=(1088, 1920), layout="body25b")


def test_a_span_of_millions_of_frames_is_refused(tmp_path: Path) -> None:
    folder = crowd(tmp_path / "cam01_json", 63, 100)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(InputError, match=r"cam01_json: frames 0 to 6200000 span 6200001 frames; at most 1000000"):
        read(folder)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # kB


def test_frames_times_people_are_bounded(tmp_path: Path) -> None:
    folder = crowd(tmp_path / "cam01_json", 10, 100)
    with pytest.raises(
        InputError, match=r"900001 frames with up to 100 people in one frame are 90000100 person-frames"
    ):
        read(folder)


def test_a_long_take_of_few_people_is_read(tmp_path: Path) -> None:
    tracks = read_openpose_folder(
        crowd(tmp_path / "cam01_json", 3, 1), fps=60.0, image_size=(1088, 1920), layout="body25b"
    )
    assert tracks.num_frames == 200_001
