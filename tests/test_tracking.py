"""Tracking: real MoveNet detections of the Sports2D demo, and constructed crossings, gaps and fragments."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from detectors.cache import read_detections
from detectors.keypoints import to_our_joints
from detectors.tracking import TrackerConfig, select_persons, track_detections
from lifting.errors import InputError

# A standing person (17 joints, our order) about 100 px tall, feet at y = 0.
_BODY = np.array(
    [[0, -50], [-10, -50], [-10, -25], [-10, 0], [10, -50], [10, -25], [10, 0], [0, -65], [0, -80],
     [0, -88], [0, -95], [15, -80], [18, -65], [20, -50], [-15, -80], [-18, -65], [-20, -50]],
    dtype=np.float64,
)  # fmt: skip


def _person(x: float, y: float, confidence: float = 0.9) -> np.ndarray:
    pose = np.empty((17, 3))
    pose[:, :2] = _BODY + (x, y)
    pose[:, 2] = confidence
    return pose


def _frames(*people_per_frame: list[np.ndarray]) -> list[np.ndarray]:
    return [np.stack(people) if people else np.zeros((0, 17, 3)) for people in people_per_frame]


@pytest.fixture(scope="module")
def demo_detections(data_dir: Path) -> tuple[list[np.ndarray], np.ndarray]:
    """Real MoveNet detections of the Sports2D demo (COCO-17 layout) on our joints, and their frame indices."""
    _, detections, indices = read_detections(data_dir / "video/sports2d-demo/movenet-detections.npz")
    return [to_our_joints(people, "coco17") for people in detections], indices


def test_sports2d_demo_people_keep_one_id(demo_detections) -> None:
    """The man on the box (whole clip, jumps down) and the woman walking across each keep one track ID."""
    detections, indices = demo_detections
    tracks = track_detections(detections, indices / 30.0, (994, 1768), "demo")
    seen = (tracks.keypoints[..., 2] > 0).any(axis=2)
    assert tracks.num_persons == 2
    man, woman = 0, 1  # IDs in order of first appearance; the man is there from frame 0
    assert seen[0, man] and not seen[0, woman]
    assert np.nonzero(seen[:, man])[0][[0, -1]].tolist() == [0, 225]
    first, last = np.nonzero(seen[:, woman])[0][[0, -1]]
    assert first < 45 and last > 190
    # the man starts on the box (upper image), ends on the grass; the woman stays on the grass
    man_y = np.nanmean(tracks.keypoints[[5, 220], man, :, 1], axis=1)
    assert man_y[0] < 400 and man_y[1] > 600
    assert np.nanmean(tracks.keypoints[seen[:, woman], woman, :, 1], axis=1).min() > 550


def test_person_selection(demo_detections) -> None:
    detections, indices = demo_detections
    tracks = track_detections(detections, indices / 30.0, (994, 1768), "demo")
    assert select_persons(tracks, "all").num_persons == 2
    largest = select_persons(tracks, "largest")
    assert largest.num_persons == 1
    sizes = [np.nansum(np.ptp(tracks.keypoints[:, p, :, 1], axis=1)) for p in range(2)]
    assert largest.track_ids[0] == tracks.track_ids[int(np.argmax(sizes))]
    assert select_persons(tracks, "5").num_persons == 2
    with pytest.raises(InputError, match="--persons"):
        select_persons(tracks, "tallest")


def test_crossing_people_keep_their_ids() -> None:
    """Two people walk through each other at constant speed; motion prediction keeps them apart."""
    times = np.arange(40) / 30.0
    frames = _frames(*[[_person(100 + 10 * t, 300), _person(490 - 10 * t, 305)][:: (-1) ** t] for t in range(40)])
    tracks = track_detections(frames, times, (600, 800), "crossing")
    assert tracks.num_persons == 2
    x = np.nanmean(tracks.keypoints[:, :, :, 0], axis=2)
    assert np.all(np.diff(x[:, 0]) > 0) and np.all(np.diff(x[:, 1]) < 0)


def test_short_gap_is_bridged_and_left_missing() -> None:
    times = np.arange(30) / 30.0
    frames = _frames(*[[] if 10 <= t < 20 else [_person(100 + 5 * t, 300)] for t in range(30)])
    tracks = track_detections(frames, times, (600, 800), "gap")
    assert tracks.num_persons == 1
    assert (tracks.keypoints[10:20, 0, :, 2] == 0).all() and np.isnan(tracks.keypoints[10:20, 0, :, :2]).all()
    np.testing.assert_allclose(tracks.keypoints[25, 0, :, :2], _person(225, 300)[:, :2])


def test_long_gap_fragments_are_stitched_but_far_people_are_not() -> None:
    config = TrackerConfig(max_gap_s=0.3, stitch_gap_s=2.0)
    times = np.arange(60) / 30.0
    near = _frames(*[[] if 10 <= t < 40 else [_person(100 + 2 * t, 300)] for t in range(60)])
    assert track_detections(near, times, (600, 800), "near", config).num_persons == 1
    far = _frames(*[[] if 10 <= t < 40 else [_person(100 if t < 10 else 700, 300)] for t in range(60)])
    assert track_detections(far, times, (600, 800), "far", config).num_persons == 2


def test_spurious_short_detections_are_dropped() -> None:
    times = np.arange(20) / 30.0
    frames = _frames(*[[_person(100, 300)] + ([_person(600, 300)] if t == 5 else []) for t in range(20)])
    tracks = track_detections(frames, times, (600, 800), "spurious")
    assert tracks.num_persons == 1


def test_stored_demo_detections_are_the_bundled_detector_output(data_dir: Path, demo_detections) -> None:
    """The stored detections are what the bundled MoveNet gives today (checked on 3 frames)."""
    from detectors.contracts import load_detector
    from detectors.video import iter_frames

    detections, indices = demo_detections
    detector = load_detector(threads=1)
    checked = 0
    for index, frame in iter_frames(data_dir / "video/sports2d-demo/demo.mp4", stride=100):
        fresh = to_our_joints(detector(frame), detector.layout)
        stored = detections[int(np.searchsorted(indices, index))]
        assert fresh.shape == stored.shape
        np.testing.assert_allclose(fresh, stored, atol=0.05, equal_nan=True)
        checked += 1
    assert checked == 3
