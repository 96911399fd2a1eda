"""Per-frame people read from a file, in any keypoint layout, -> tracks on our joints (shared by every reader).

Frame numbers missing between the first and the last become frames with no
detection (NaN, confidence 0), so times stay right. Implausible values (a gap
of many frames, a crowd, points far outside the image) are refused by
:mod:`detectors.sources.keypoint_checks` before any tracking. People that all carry a
track ID keep it; otherwise :mod:`detectors.tracking.tracker` assigns IDs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from platypose.detectors.keypoints import to_our_joints
from platypose.detectors.sources.keypoint_checks import (
    check_fps,
    check_frame_numbers,
    check_frame_span,
    check_image_size,
    check_people_count,
    check_points,
)
from platypose.detectors.tracking.tracker import TrackerConfig, track_detections, tracks_from_ids
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import KEYPOINT_LAYOUTS


@dataclass(frozen=True)
class Person:
    """One detected person in a file: keypoints (S, 3) x, y, confidence in the file's layout; ID if the file has one."""

    keypoints: np.ndarray
    track_id: int | None = None


def check_layout(source: str, layout: str, people: list[Person]) -> None:
    """InputError unless ``layout`` is known and every person has its number of points."""
    if layout not in KEYPOINT_LAYOUTS:
        raise InputError(f"{source}: unknown keypoint layout {layout!r}; known: {', '.join(KEYPOINT_LAYOUTS)}")
    expected = len(KEYPOINT_LAYOUTS[layout][0])
    counts = {person.keypoints.shape for person in people}
    if counts - {(expected, 3)}:
        found = ", ".join(str(shape) for shape in sorted(counts))
        raise InputError(f"{source}: layout {layout} has {expected} points per person, the file has {found}")


def assemble_tracks(
    frames: dict[int, list[Person]],
    layout: str,
    fps: float,
    image_size: tuple[int, int],
    source: str,
    tracker: TrackerConfig = TrackerConfig(),
    time_origin: int = 0,
) -> PoseTrack2D:
    """Frame number -> people, in ``layout`` -> tracks; frame ``n`` is at ``(n - time_origin) / fps`` seconds."""
    if not frames:
        raise InputError(f"{source}: no frames")
    fps = check_fps(source, fps)
    image_size = check_image_size(source, image_size)
    check_frame_numbers(source, frames)
    everyone = [person for people in frames.values() for person in people]
    check_layout(source, layout, everyone)
    for number, people in frames.items():
        check_people_count(source, number, len(people))
        if people:
            check_points(source, np.stack([p.keypoints for p in people]), image_size, f"frame {number}: ")
    check_frame_span(source, min(frames), max(frames), max(len(people) for people in frames.values()))
    numbers = np.arange(min(frames), max(frames) + 1)
    times = (numbers - time_origin) / fps
    detections = [
        to_our_joints(np.stack([p.keypoints for p in frames[n]]), layout) if frames.get(n) else np.zeros((0, 17, 3))
        for n in numbers
    ]
    if everyone and all(person.track_id is not None for person in everyone):
        ids = [np.array([p.track_id for p in frames.get(n, [])], dtype=np.int64) for n in numbers]
        try:
            return tracks_from_ids(ids, detections, times, image_size, source)
        except ValueError as err:
            raise InputError(f"{source}: {err}") from None
    return track_detections(detections, times, image_size, source, tracker)
