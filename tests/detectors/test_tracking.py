"""Tracking: real MoveNet detections of the Sports2D demo, and constructed crossings, gaps, fragments and ID switches."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.cache import read_detections
from platypose.detectors.keypoints import to_our_joints
from platypose.detectors.tracking.id_repair import repair_id_switches
from platypose.detectors.tracking.pose_metrics import person_size
from platypose.detectors.tracking.tracker import TrackerConfig, select_persons, track_detections
from platypose.lifting.errors import InputError
from platypose.lifting.skeleton import MIRROR

# A standing person (17 joints, our order) about 100 px tall, feet at y = 0.
_BODY = np.array(
    [
        [0, -50],
        [-10, -50],
        [-10, -25],
        [-10, 0],
        [10, -50],
        [10, -25],
        [10, 0],
        [0, -65],
        [0, -80],
        [0, -88],
        [0, -95],
        [15, -80],
        [18, -65],
        [20, -50],
        [-15, -80],
        [-18, -65],
        [-20, -50],
    ],
    dtype=np.float64,
)


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
    assert select_persons(tracks, "largest:5").num_persons == 2
    with pytest.raises(InputError, match="persons must be"):
        select_persons(tracks, "tallest")


def test_persons_by_id_and_by_a_pixel_where_first_seen(demo_detections) -> None:
    """The Sports2D demo's two tracks chosen by their ids (as the outputs name them) and by a pixel inside or near
    the box of a track's joints in the first frame it is seen; an unknown id names the ids there are."""
    detections, indices = demo_detections
    tracks = track_detections(detections, indices / 30.0, (994, 1768), "demo")
    ids = [int(t) for t in tracks.track_ids]
    assert select_persons(tracks, f"{ids[1]},").track_ids.tolist() == [ids[1]]
    assert select_persons(tracks, f"{ids[1]},{ids[0]}").track_ids.tolist() == ids
    with pytest.raises(InputError, match=f"no track with id 99 \\(ids: {ids[0]}, {ids[1]}\\)"):
        select_persons(tracks, "99,")
    for p in range(2):
        seen = tracks.keypoints[..., 2] > 0
        first = np.flatnonzero(seen[:, p].sum(axis=-1) >= 4)[0]
        x, y = tracks.keypoints[first, p, seen[first, p], :2].mean(axis=0)
        assert select_persons(tracks, f"@{x:.0f},{y:.0f}").track_ids.tolist() == [ids[p]]
        assert select_persons(tracks, f"@{x:.0f},{y + 5:.0f}").track_ids.tolist() == [ids[p]]
    for bad in ("@1", "@a,b", "-1,2", ","):
        with pytest.raises(InputError, match="persons must be"):
            select_persons(tracks, bad)


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
    from platypose.detectors.models.contracts import load_detector
    from platypose.detectors.sources.video import iter_frames

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


# --- ID-switch repair: real poses of the Sports2D demo, moved, mirrored, swapped -------------------------------------


@pytest.fixture(scope="module")
def demo_tracks(demo_detections) -> tuple[np.ndarray, np.ndarray]:
    """The demo's two tracks (T, 2, 17, 3) as tracking and stitching give them (no repair), and frame times (T,)."""
    detections, indices = demo_detections
    times = indices / 30.0
    config = TrackerConfig(repair_switches=False)
    return track_detections(detections, times, (994, 1768), "demo", config).keypoints, times


def _centres(poses: np.ndarray) -> np.ndarray:
    """Median of the visible joints, (..., 17, 3) -> (..., 2)."""
    visible = np.where(poses[..., 2:] > 0.2, poses[..., :2], np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmedian(visible, axis=-2)


def _woman_on_man(keypoints: np.ndarray) -> np.ndarray:
    """The demo tracks with the woman moved (one constant shift) so that she walks through the man at frame 75."""
    moved = keypoints.copy()
    centres = _centres(keypoints[75])
    moved[:, 1, :, :2] += centres[0] - centres[1]
    return moved


def _swapped(keypoints: np.ndarray, frame: int) -> np.ndarray:
    """Tracks (T, 2, 17, 3) with the two people's identities switched from ``frame`` on."""
    switched = keypoints.copy()
    switched[frame:] = keypoints[frame:, ::-1]
    return switched


def _mirrored(walk: np.ndarray, scale: float, meet: int) -> np.ndarray:
    """A real walk (T, 17, 3) mirrored left-right about its centre at frame ``meet`` and scaled by ``scale`` about it:
    a smaller (or equal) person walking the other way who meets the original there."""
    centre = _centres(walk[meet])
    mirrored = walk[:, list(MIRROR)].copy()
    mirrored[..., 0] = 2 * centre[0] - mirrored[..., 0]
    mirrored[..., :2] = centre + scale * (mirrored[..., :2] - centre)
    return mirrored


def _walkers(walk: np.ndarray, scale: float, meet: int, bounce: bool = False) -> list[np.ndarray]:
    """Per-frame detections of a real walk (T, 17, 3) and its ``_mirrored`` copy; they meet at frame ``meet`` and
    pass each other (or both turn back there, ``bounce``)."""
    if bounce:
        walk = np.concatenate([walk[:meet], walk[meet - np.arange(len(walk) - meet)]])
    people = [[p for p in pair if (p[:, 2] > 0.2).sum() >= 4] for pair in zip(walk, _mirrored(walk, scale, meet))]
    return [np.stack(pair) if pair else np.zeros((0, 17, 3)) for pair in people]


def _direction_and_size(keypoints: np.ndarray, frames: slice) -> tuple[np.ndarray, np.ndarray]:
    """Per track (T, P, 17, 3): median x-centre and median size over ``frames``, (P,) each."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        x = np.nanmedian(_centres(keypoints[frames])[..., 0], axis=0)
        return x, np.nanmedian(person_size(keypoints[frames], 0.2), axis=0)


def test_repair_changes_nothing_on_the_demo(demo_detections, demo_tracks) -> None:
    """The man (ID 0) and the woman (ID 1) stay as they are, also when the woman is moved to walk through the man."""
    keypoints, times = demo_tracks
    detections, _ = demo_detections
    default = track_detections(detections, times, (994, 1768), "demo")  # repair is on by default
    np.testing.assert_array_equal(default.keypoints, keypoints)
    assert repair_id_switches(keypoints, times)[1] == []
    moved = _woman_on_man(keypoints)
    centres, sizes = _centres(moved), person_size(moved, 0.2)
    with np.errstate(invalid="ignore"):
        near = np.linalg.norm(centres[:, 0] - centres[:, 1], axis=-1) < np.fmax(sizes[:, 0], sizes[:, 1])
    assert near.sum() >= 40  # within one person size of each other in 44 frames (45-93)
    repaired, swaps = repair_id_switches(moved, times)
    assert swaps == []
    np.testing.assert_array_equal(repaired, moved)


@pytest.mark.parametrize("frame", [60, 75, 90])
def test_injected_switch_of_real_people_is_repaired(demo_tracks, frame: int) -> None:
    """The man and the woman (moved to walk through him) switched from a frame on: the repair swaps them back there."""
    keypoints, times = demo_tracks
    moved = _woman_on_man(keypoints)
    repaired, swaps = repair_id_switches(_swapped(moved, frame), times)
    assert swaps == [(frame, 0, 1)]
    np.testing.assert_array_equal(repaired, moved)


def test_two_switches_among_three_real_people_are_repaired(demo_tracks) -> None:
    """The man, the moved woman and a smaller mirrored copy of her meeting her at frame 150: she is switched with the
    man at 60 and then (from his column) with the copy at 150; both switches are undone, in order."""
    keypoints, times = demo_tracks
    moved = _woman_on_man(keypoints)
    three = np.concatenate([moved, _mirrored(moved[:, 1], 0.75, meet=150)[:, None]], axis=1)
    assert repair_id_switches(three, times)[1] == []
    switched = _swapped(three[:, :2], 60)
    switched = np.concatenate([switched, three[:, 2:]], axis=1)
    switched[150:, [0, 2]] = switched[150:, [2, 0]]
    repaired, swaps = repair_id_switches(switched, times)
    assert swaps == [(60, 0, 1), (150, 1, 2)]
    np.testing.assert_array_equal(repaired, three)


@pytest.mark.parametrize("scale", [1.0, 0.75])
def test_real_walkers_crossing_keep_their_ids(demo_tracks, scale: float) -> None:
    """The woman's real walk and a mirrored, scaled copy pass each other: each track keeps its direction and size,
    also when both are missed while they overlap and stitching alone would join them wrongly."""
    keypoints, times = demo_tracks
    frames = _walkers(keypoints[:, 1].astype(np.float64), scale, meet=115)
    hidden = [np.zeros((0, 17, 3)) if 110 <= t < 150 else people for t, people in enumerate(frames)]
    for detections in (frames, hidden):
        tracks = track_detections(detections, times, (994, 1768), "walkers").keypoints
        assert tracks.shape[1] == 2
        x_start, size_start = _direction_and_size(tracks, slice(50, 100))
        x_end, size_end = _direction_and_size(tracks, slice(160, 190))
        assert x_end[0] < x_start[0] - 500 and x_end[1] > x_start[1] + 500  # she walks left, her copy right
        np.testing.assert_allclose(size_start[1] / size_start[0], scale, atol=0.05)
        np.testing.assert_allclose(size_end[1] / size_end[0], scale, atol=0.05)
    unrepaired = track_detections(hidden, times, (994, 1768), "walkers", TrackerConfig(repair_switches=False))
    x_end = _direction_and_size(unrepaired.keypoints, slice(160, 190))[0]
    assert x_end[0] > x_end[1]  # without the repair the stitched tracks turn back: the switch the repair undoes


def test_walkers_of_different_size_turning_back_are_not_swapped(demo_tracks) -> None:
    """Two real walkers of different size meet and both turn back: motion alone would say they passed each other,
    but their body sizes keep each identity."""
    keypoints, times = demo_tracks
    frames = _walkers(keypoints[:, 1].astype(np.float64), 0.75, meet=115, bounce=True)
    tracks = track_detections(frames, times, (994, 1768), "bounce").keypoints
    x_start, size_start = _direction_and_size(tracks, slice(50, 100))
    x_end, size_end = _direction_and_size(tracks, slice(130, 180))
    np.testing.assert_allclose(size_end / size_start, 1.0, atol=0.05)
    np.testing.assert_allclose(x_end, x_start, atol=60)


@pytest.mark.parametrize("delay", [10, 20])
def test_no_swap_on_a_coin_flip(demo_tracks, delay: int) -> None:
    """The man and a copy of himself a few frames late and 15 px aside, switched: too alike to tell, left as they are."""
    keypoints, times = demo_tracks
    man = keypoints[:110, 0]
    late = np.concatenate([keypoints[:delay, 1], man[:-delay]])  # the woman's first frames: all missing
    late[..., 0] += 15
    twins = _swapped(np.stack([man, late], axis=1), 40)
    repaired, swaps = repair_id_switches(twins, times[:110])
    assert swaps == []
    np.testing.assert_array_equal(repaired, twins)
