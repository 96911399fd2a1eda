"""Cross-view person matching on the real Pose2Sim calibration and OpenPose keypoints of 4 views."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.persons.multiview import match_across_views
from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.calibration import load_calibration

NAMES = ("cam01", "cam02", "cam03", "cam04")


@pytest.fixture(scope="module")
def cameras(data_dir: Path):
    return list(load_calibration(data_dir / "video/pose2sim-balancing/calib_pose2sim.toml").cameras)


@pytest.fixture(scope="module")
def views(data_dir: Path):
    folder = data_dir / "video/pose2sim-balancing/openpose-body25b"
    return [read_openpose_folder(folder / f"{name}_json") for name in NAMES]


def _seen(track) -> np.ndarray:
    return (track.keypoints[..., 2] > 0).any(axis=2).sum(axis=0)


def test_four_views_share_person_ids(views, cameras) -> None:
    """The athlete is one person in all 4 views; the person in the background only in cam01 and cam02."""
    shuffled = [views[0], views[1].select([1, 0]), views[2], views[3]]  # cam02's tracks in the other order
    matched = match_across_views(shuffled, cameras)
    assert [m.track_ids.tolist() for m in matched] == [[0, 1]] * 4
    assert [_seen(m).tolist() for m in matched] == [[100, 100], [100, 100], [100, 0], [100, 0]]
    for original, m in zip(shuffled, matched):  # the athlete (the tall one) is ID 0 in every view
        athlete = int(np.argmax([_height(original, p) for p in range(original.num_persons)]))
        np.testing.assert_array_equal(m.keypoints[:, 0], original.keypoints[:, athlete])


def _height(track, p: int) -> float:
    y = track.keypoints[:, p, :, 1]
    return float(np.nanmedian(np.nanmax(y, axis=1) - np.nanmin(y, axis=1)))


def test_a_different_person_is_not_matched(views, cameras) -> None:
    moved = views[3].keypoints.copy()
    moved[..., 0] += 250.0  # cam04's athlete moved sideways: no longer consistent with the other views
    impostor = PoseTrack2D(moved, views[3].frame_times, views[3].track_ids, views[3].image_size, "moved")
    matched = match_across_views([views[0], views[1], views[2], impostor], cameras)
    assert matched[0].num_persons == 3  # athlete, background person, and the impostor on its own
    assert _seen(matched[3]).tolist().count(100) == 1 and _seen(matched[0])[np.argmax(_seen(matched[3]))] == 0
