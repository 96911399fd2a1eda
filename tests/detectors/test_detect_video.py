"""The bundled MoveNet on real Pose2Sim frames against the shipped OpenPose keypoints; streaming; cache; bad videos."""

from __future__ import annotations

import os
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.keypoints import to_our_joints
from platypose.detectors.models.contracts import load_detector
from platypose.detectors.models.movenet import decode_movenet
from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.detectors.sources.video import iter_frames, video_info
from platypose.detectors.video_detection import detect_frames, detect_video
from platypose.lifting.errors import InputError
from platypose.lifting.skeleton import JOINT_INDEX

POSE2SIM = "video/pose2sim-balancing"


@pytest.fixture(scope="module")
def movenet():
    return load_detector(threads=1)


@pytest.mark.parametrize("camera", ["cam01", "cam02"])
def test_movenet_lands_on_the_openpose_person(data_dir: Path, movenet, camera: str) -> None:
    """Every 20th frame: the main person's joints are within 30 px (median) of OpenPose's (measured ~11-17 px)."""
    openpose = read_openpose_folder(data_dir / POSE2SIM / f"openpose-body25b/{camera}_json")
    main = int(np.argmax((openpose.keypoints[..., 2] > 0).sum(axis=(0, 2))))
    joints = [j for j in range(17) if j != JOINT_INDEX["neck"]]  # BODY_25B observes the neck differently
    distances = []
    for index, frame in iter_frames(data_dir / POSE2SIM / f"{camera}.mp4", stride=20):
        people = movenet(frame)
        assert people.shape[1:] == (17, 3)
        ours = to_our_joints(people, movenet.layout)[:, joints]
        reference = openpose.keypoints[index, main, joints]
        per_person = np.nanmedian(np.linalg.norm(ours[..., :2] - reference[:, :2], axis=-1), axis=1)
        distances.append(per_person.min())
    assert len(distances) == 5
    assert np.median(distances) < 30, distances
    assert max(distances) < 60, distances


def test_detect_video_streams_and_caches(data_dir: Path, movenet, tmp_path: Path) -> None:
    video = data_dir / POSE2SIM / "cam02.mp4"
    calls = []

    class Counting:
        name, layout = movenet.name, movenet.layout

        def __call__(self, image: np.ndarray) -> np.ndarray:
            calls.append(image.shape)
            return movenet(image)

    progress = []
    tracks = detect_video(
        video, Counting(), stride=10, max_frames=4, cache_dir=tmp_path, progress=lambda d, t: progress.append((d, t))
    )
    assert len(calls) == 4 and progress[-1] == (4, 4)
    assert tracks.image_size == (1920, 1080)
    np.testing.assert_allclose(tracks.frame_times, np.array([0, 10, 20, 30]) / 60.0)
    confident_joints = (tracks.keypoints[..., 2] > 0.3).sum(axis=2)  # (T, P)
    assert (confident_joints.max(axis=1) >= 12).all()  # the man on the plate, in every frame
    assert (tmp_path / "cam02.detections.npz").is_file()
    again = detect_video(video, Counting(), stride=10, max_frames=4, cache_dir=tmp_path)
    assert len(calls) == 4  # read from the cache
    np.testing.assert_array_equal(again.keypoints, tracks.keypoints)
    detect_video(video, Counting(), stride=5, max_frames=4, cache_dir=tmp_path)
    assert len(calls) == 8  # other settings: the stale cache is not used


def _keypoints_swapped(path: Path) -> None:
    """The cache with its keypoints one frame short of its counts: arrays that do not fit together."""
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["keypoints"] = arrays["keypoints"][:-1]
    np.savez(path, **arrays)


@pytest.mark.parametrize(
    "damage",
    [lambda path: os.truncate(path, path.stat().st_size // 2), _keypoints_swapped],
    ids=["truncated", "arrays that do not fit"],
)
def test_a_damaged_detection_cache_is_removed_and_detected_again(data_dir: Path, movenet, tmp_path: Path, damage):
    """A detection cache cut short, or whose arrays do not fit together, is not read (no BadZipFile, no
    IndexError): the video is detected again, the cache rewritten, and the tracks' notes say so."""
    video = data_dir / POSE2SIM / "cam02.mp4"
    first = detect_video(video, movenet, stride=10, max_frames=4, cache_dir=tmp_path)
    damage(tmp_path / "cam02.detections.npz")
    again = detect_video(video, movenet, stride=10, max_frames=4, cache_dir=tmp_path)
    np.testing.assert_array_equal(again.keypoints, first.keypoints)
    (note,) = [n for n in again.notes if "damaged detection cache" in n]
    assert note.startswith(f"{tmp_path / 'cam02.detections.npz'}: damaged detection cache (") and note.endswith(
        "); removed, detected again"
    )
    assert detect_video(video, movenet, stride=10, max_frames=4, cache_dir=tmp_path).notes == first.notes


def test_detection_holds_one_frame_at_a_time(data_dir: Path) -> None:
    """40 full-HD frames pass through detection; memory peaks at a few frames, not 40."""

    class Nothing:
        name, layout = "nothing", "coco17"

        def __call__(self, image: np.ndarray) -> np.ndarray:
            return np.zeros((0, 17, 3))

    frame_bytes = 1920 * 1080 * 3
    tracemalloc.start()
    detections, indices = detect_frames(data_dir / POSE2SIM / "cam01.mp4", Nothing(), max_frames=40)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert len(detections) == 40 and indices[-1] == 39
    assert peak < 4 * frame_bytes


def test_unreadable_videos(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="video file not found"):
        video_info(tmp_path / "missing.mp4")
    garbage = tmp_path / "garbage.mp4"
    garbage.write_bytes(b"this is not a video" * 100)
    with pytest.raises(InputError, match=r"garbage\.mp4: (cannot read video \(Invalid data|no decodable frame)"):
        video_info(garbage)
    with pytest.raises(InputError, match=r"garbage\.mp4"):
        list(iter_frames(garbage))


def test_box_downscale_is_close_to_area_averaging(data_dir: Path, movenet) -> None:
    """On real frames the box-filter shrink MoveNet uses differs from INTER_AREA by a few grey levels, and MoveNet
    finds the same joints on both images (within 3 px median; measured over the balancing take: the same 12.1 px
    median distance to OpenPose's keypoints either way)."""
    import cv2

    from platypose.detectors.models.letterbox import box_downscale, fit_size, letterbox

    for _, frame in iter_frames(data_dir / POSE2SIM / "cam01.mp4", stride=25):
        size = fit_size(frame.shape[:2], movenet.longest, 32)
        area, placement = letterbox(frame, size)
        box, same = letterbox(frame, size, box_filter=True)
        assert same == placement
        assert np.abs(area.astype(int) - box.astype(int)).mean() < 3
        h, w = round(frame.shape[0] * placement.scale[1]), round(frame.shape[1] * placement.scale[0])
        assert np.array_equal(box[:h, :w], box_downscale(frame, (h, w)))
        rows = movenet.session.run(
            None, {movenet.input_name: cv2.cvtColor(area, cv2.COLOR_BGR2RGB)[None].astype(np.int32)}
        )
        people = movenet(frame)
        reference = decode_movenet(rows[0][0], placement, movenet.min_score)
        assert len(people) == len(reference) >= 1
        distances = np.linalg.norm(people[:, None, :, :2] - reference[None, :, :, :2], axis=-1)  # (N, M, 17)
        assert np.median(distances, axis=-1).min(axis=1).max() < 3  # each person found on both, same joints
