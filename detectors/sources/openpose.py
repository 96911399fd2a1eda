"""Read an OpenPose JSON folder (one ``*.json`` per frame; BODY_25, BODY_25B, COCO-18, Halpe-26) into tracks.

The frame number of each file is the last group of digits in its name
(``cam01.0042.json``, ``video_000000000042_keypoints.json``). Frame times are
``frame_number / fps``. Missing frame numbers between the first and the last
file are kept as frames with no detection (NaN, confidence 0), so times stay
right; the gap is reported by :func:`missing_frames`. A file numbered far past
the others (more than ``keypoint_checks.MAX_GAP_FRAMES`` after the one before)
is an error naming it. OpenPose's ``person_id``
is usually -1, so people are tracked by :mod:`detectors.tracking.tracker`. A point
OpenPose did not find is written as (0, 0, 0) and becomes missing.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from platypose.detectors.sources.assemble import Person, assemble_tracks
from platypose.detectors.sources.keypoint_checks import check_frame_numbers, describe_parse_error
from platypose.detectors.sources.video import timing_from_video
from platypose.detectors.tracking.tracker import TrackerConfig
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.errors import InputError

_LAYOUT_BY_COUNT = {17: "coco17", 18: "coco18", 26: "halpe26", 133: "wholebody133"}


def frame_number(path: Path) -> int:
    """The frame number in a per-frame file name: its last group of digits."""
    digits = re.findall(r"\d+", path.stem)
    if not digits:
        raise InputError(f"{path}: no frame number in the file name")
    return int(digits[-1])


def _read_people(path: Path) -> list[np.ndarray]:
    """Each person's ``pose_keypoints_2d`` of one OpenPose file as (S, 3) arrays."""
    try:
        people = json.loads(path.read_text())["people"]
        poses = [np.asarray(person["pose_keypoints_2d"], dtype=np.float64) for person in people]
    except (OSError, ValueError, KeyError, TypeError, RecursionError) as err:
        raise InputError(f"{path}: not an OpenPose keypoint file ({describe_parse_error(err)})") from None
    for pose in poses:
        if pose.ndim != 1 or pose.size == 0 or pose.size % 3:
            raise InputError(f"{path}: pose_keypoints_2d has {pose.size} numbers, not a multiple of 3")
    return [pose.reshape(-1, 3) for pose in poses]


def guess_layout(poses: list[np.ndarray]) -> str:
    """The keypoint layout of OpenPose poses (each (S, 3)) from the point count and, for 25 points, geometry.

    Points 15-16 are the ankles in BODY_25B but the eyes in BODY_25, and points
    11-14 are hips and knees in BODY_25B but ankles, hip and knee in BODY_25: in
    image coordinates (y down) of upright people, 15-16 lie below 11-14 only in BODY_25B.
    """
    count = poses[0].shape[0]
    if count in _LAYOUT_BY_COUNT:
        return _LAYOUT_BY_COUNT[count]
    if count != 25:
        raise ValueError(f"{count} keypoints per person match no known layout (17, 18, 25, 26, 133)")
    below = []
    for pose in poses:
        upper, lower = pose[15:17], pose[11:15]
        if (upper[:, 2] > 0).any() and (lower[:, 2] > 0).any():
            below.append(upper[upper[:, 2] > 0, 1].mean() > lower[lower[:, 2] > 0, 1].mean())
    if not below:
        raise ValueError("cannot tell BODY_25 from BODY_25B (no person with points 11-16); pass the layout")
    return "body25b" if np.mean(below) > 0.5 else "body25"


def read_openpose_folder(
    folder: str | Path,
    fps: float | None = None,
    image_size: tuple[int, int] | None = None,
    layout: str | None = None,
    tracker: TrackerConfig = TrackerConfig(),
) -> PoseTrack2D:
    """Read an OpenPose JSON folder into tracks (T, P, 17, 3) on our joints.

    ``fps`` and ``image_size`` (height, width) not given are read from the video
    the folder was made from (``cam01.mp4`` for ``cam01_json``, beside the folder
    or one level up); InputError if there is none. ``layout`` (``body25``,
    ``body25b``, ``coco18``, ``halpe26``, ``coco17``) is guessed when not given.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder of OpenPose JSON files")
    files = sorted(folder.glob("*.json"))
    if not files:
        raise InputError(f"{folder}: no .json files")
    numbers = [frame_number(path) for path in files]
    if len(set(numbers)) != len(numbers):
        raise InputError(f"{folder}: two files have the same frame number")
    check_frame_numbers(str(folder), numbers, {n: path.name for n, path in zip(numbers, files)})
    fps, image_size = timing_from_video(folder, fps, image_size)
    frames = {number: [Person(pose) for pose in _read_people(path)] for number, path in zip(numbers, files)}
    everyone = [person.keypoints for people in frames.values() for person in people]
    if layout is None:
        if not everyone:
            raise InputError(f"{folder}: no person in any file")
        if len({pose.shape[0] for pose in everyone}) > 1:
            raise InputError(f"{folder}: files disagree on the number of keypoints per person")
        try:
            layout = guess_layout(everyone)
        except ValueError as err:
            raise InputError(f"{folder}: {err}") from None
    return assemble_tracks(frames, layout, fps, image_size, str(folder), tracker)


def missing_frames(folder: str | Path) -> np.ndarray:
    """Frame numbers between the first and last file of a per-frame JSON folder that have no file."""
    numbers = np.array([frame_number(path) for path in Path(folder).glob("*.json")], dtype=np.int64)
    if numbers.size == 0:
        return numbers
    return np.setdiff1d(np.arange(numbers.min(), numbers.max() + 1), numbers)
