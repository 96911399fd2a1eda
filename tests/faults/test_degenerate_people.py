"""People no file can show: a lift collapsed to one point has no bones (no BVH rotation, no OpenSim scale) and its
frames are gaps, said once; a person wholly outside the image has no picture (no box to cut)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from export_helpers import camera_facing, climb_joints, make_result

from platypose.exporters.export import export
from platypose.exporters.person_pictures import good_frame, thumbnails

DATA = Path(__file__).resolve().parents[2] / "data"
VIDEO = DATA / "video/pose2sim-balancing/cam01.mp4"


def collapsed_result(frames: slice = slice(None)):
    """A real climb with the person's 17 joints at the pelvis in ``frames``."""
    joints, fps = climb_joints(DATA, 30)
    result = make_result(joints, fps, 4, (camera_facing(joints),))
    hypotheses = np.array(result.hypotheses)
    hypotheses[:, :, frames] = hypotheses[:, :, frames, :1]
    return replace(result, hypotheses=hypotheses, median=np.median(hypotheses, axis=1))


def test_a_person_collapsed_in_every_frame_is_said_and_not_written(tmp_path: Path) -> None:
    said: list[str] = []
    written = export(collapsed_result(), tmp_path, "take", ["bvh", "trc", "csv", "npz"], say=said.append)
    assert sorted(p.name for p in written) == ["take.csv", "take.npz", "take_gaps.json"]
    assert (
        "take: person 3: every frame's joints lie within a few centimetres of one point (a collapsed lift, no body): "
        "no csv, bvh, trc written for this person"
    ) in said


def test_collapsed_frames_are_gaps_of_the_bvh(tmp_path: Path) -> None:
    said: list[str] = []
    written = export(collapsed_result(slice(10, 14)), tmp_path, "take", ["bvh"], say=said.append)
    assert [p.name for p in written] == ["take_p3.bvh", "take_gaps.json"]
    assert any("person 3 gaps:" in line and "10" in line for line in said), said
    lines = (tmp_path / "take_p3.bvh").read_text().splitlines()
    assert np.isfinite(np.array([line.split() for line in lines[-30:]], dtype=float)).all()


def test_a_person_outside_the_image_has_no_picture() -> None:
    keypoints = np.zeros((1, 5, 17, 3))
    keypoints[..., 0] = np.linspace(-1900, -100, 17)  # left of the image (allowed down to -W)
    keypoints[..., 1] = np.linspace(1200, 2000, 17)[None, None]  # below it
    keypoints[..., 2] = 0.9
    assert good_frame(keypoints, [(1088, 1920)]) is None
    partly = keypoints.copy()
    partly[0, 2, :6, :2] = [[500, 300], [520, 340], [540, 380], [560, 420], [580, 460], [600, 500]]
    good = good_frame(partly, [(1088, 1920)])
    assert good is not None and good.frame == 2 and 0 <= good.box[0] < good.box[2] <= 1919
    result = SimpleNamespace(cameras=(SimpleNamespace(name="cam01", time_offset_s=0.0),), fps=60.0)
    result.frame_times = np.arange(5) / 60.0
    assert thumbnails(result, {"cam01": VIDEO}, {0: good})[0].shape[0] == 160


def test_a_collapsed_person_gets_no_scaled_opensim_model(tmp_path: Path) -> None:
    import pytest

    pytest.importorskip("opensim")
    said: list[str] = []
    written = export(collapsed_result(), tmp_path, "take", ["mot"], say=said.append)
    assert [p.name for p in written] == ["take_gaps.json"] and not list(tmp_path.glob("*.osim"))
    assert any(
        "person 3: every frame's joints lie within a few centimetres of one point" in s and "mot" in s for s in said
    )
