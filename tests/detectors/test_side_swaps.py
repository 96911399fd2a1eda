"""Left/right label swaps of a real detector (MoveNet on the Sports2D demo) undone by continuity over time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.cache import read_detections
from platypose.detectors.keypoints import to_our_joints
from platypose.detectors.tracking.side_swaps import BODY, exchanged, repair_side_swaps
from platypose.detectors.tracking.tracker import TrackerConfig, track_detections
from platypose.lifting.skeleton import JOINT_INDEX

LEFT_HIP, RIGHT_HIP = JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]
ANKLES = (JOINT_INDEX["left_ankle"], JOINT_INDEX["right_ankle"])


def _tracks(data_dir: Path, config: TrackerConfig) -> np.ndarray:
    """The demo's tracks (T, 2, 17, 3): the man (on the roof, then down) and the walker."""
    _, detections, indices = read_detections(data_dir / "video/sports2d-demo/movenet-detections.npz")
    ours = [to_our_joints(people, "coco17") for people in detections]
    return track_detections(ours, indices / 30.0, (994, 1768), "demo", config).keypoints


@pytest.fixture(scope="module")
def raw(data_dir: Path) -> np.ndarray:
    """The demo's tracks as the detector labels them."""
    return _tracks(data_dir, TrackerConfig(repair_sides=False))


@pytest.fixture(scope="module")
def repaired(data_dir: Path) -> np.ndarray:
    """The demo's tracks as tracking gives them by default."""
    return _tracks(data_dir, TrackerConfig())


def _faces_camera_frames(tracks: np.ndarray) -> np.ndarray:
    """Frames 30-75, where the man stands on the roof facing the camera, with both hips seen."""
    frames = np.arange(30, 76)
    return frames[(tracks[frames][:, 0, [LEFT_HIP, RIGHT_HIP], 2] > 0.2).all(axis=1)]


def test_the_man_facing_the_camera_keeps_his_left_on_the_image_right(raw, repaired) -> None:
    """MoveNet labels the man's left as his right in single frames (39, 41, 70: the whole body) while he faces the
    camera: tracking relabels them, so his left hip lies right of his right hip in the image throughout."""
    frames = _faces_camera_frames(raw)
    assert len(frames) > 40
    wrong = frames[raw[frames, 0, LEFT_HIP, 0] < raw[frames, 0, RIGHT_HIP, 0]]
    assert {39, 41, 70} <= set(wrong.tolist())  # the detector's swaps
    assert (repaired[frames, 0, LEFT_HIP, 0] > repaired[frames, 0, RIGHT_HIP, 0]).all()


def test_injected_swaps_are_undone_and_nothing_else_changes(repaired) -> None:
    """Whole-body swaps over three frames and an ankle swap in one, put into the walker's repaired track where her
    sides are apart in the image (mid-stride), come back exactly; a track labelled consistently is left as it is."""
    again, changed = repair_side_swaps(repaired)
    assert changed == 0 and np.array_equal(again, repaired, equal_nan=True)
    walker = repaired[:, 1]
    apart = np.linalg.norm(walker[:, ANKLES[0], :2] - walker[:, ANKLES[1], :2], axis=-1)
    apart[~(walker[:, list(BODY), 2] > 0.2).all(axis=1)] = np.nan
    strides = np.argsort(-np.nan_to_num(apart))  # frames, feet farthest apart first
    body, ankle = np.arange(strides[0] - 1, strides[0] + 2), next(t for t in strides if abs(t - strides[0]) > 10)
    damaged = repaired.copy()
    damaged[body, 1] = exchanged(repaired[body, 1], BODY)
    damaged[ankle, 1] = exchanged(repaired[ankle, 1], ANKLES)
    mended, changed = repair_side_swaps(damaged)
    assert changed == 4
    assert np.array_equal(mended, repaired, equal_nan=True)


def test_a_track_labelled_one_way_throughout_is_kept(repaired) -> None:
    """The labels a detector gives most of the time win: a walker read mirrored in every frame stays mirrored."""
    mirrored = repaired.copy()
    mirrored[:, 1] = exchanged(repaired[:, 1], BODY)
    kept, changed = repair_side_swaps(mirrored[:, 1:])
    assert changed == 0 and np.array_equal(kept, mirrored[:, 1:], equal_nan=True)
