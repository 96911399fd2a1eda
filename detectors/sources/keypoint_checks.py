"""Plausibility checks shared by the keypoint readers: every bad value is an InputError naming the file.

Bounds (stated here):

- image size: 1 to ``MAX_IMAGE_SIDE`` pixels a side; fps: ``MIN_FPS`` to ``MAX_FPS``;
- frame numbers: whole numbers; two files (or entries) in a row may be at most ``MAX_GAP_FRAMES``
  frames apart (a longer gap is a mis-numbered file, and would be stored as that many empty frames);
- at most ``MAX_PEOPLE`` people in one frame (crowds beyond that are not what the lifter is for);
- at most ``MAX_SPAN_FRAMES`` frames from the first to the last, and at most ``MAX_PERSON_FRAMES`` frames times the
  most people in one frame: the tracks are stored densely (frames x persons), so this bounds their memory before
  any of it is taken;
- a point with confidence above 0 must be finite and lie within one image size of the image
  (x in [-W, 2W], y in [-H, 2H]): farther out it is a broken value or the wrong image size;
- frame times finite and strictly increasing.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from platypose.detectors.types import PoseTrack2D
from platypose.lifting.errors import InputError

MAX_IMAGE_SIDE = 100_000
MIN_FPS = 1.0  # slower, consecutive frames lie farther apart than a person is lifted through unseen (--max-gap 1 s)
MAX_FPS = 10_000.0
MAX_GAP_FRAMES = 100_000
MAX_PEOPLE = 100
MAX_SPAN_FRAMES = 1_000_000  # 4.6 hours at 60 fps
MAX_PERSON_FRAMES = 5_000_000  # frames x persons: 1 GiB of float32 keypoints (T, P, 17, 3)


def describe_parse_error(err: Exception) -> str:
    """A user-facing reason for an error met while reading a keypoint file's structure (no exception names)."""
    if isinstance(err, KeyError):
        return f"missing field {err}"
    if isinstance(err, (TypeError, AttributeError)):
        return f"a field has the wrong type ({err})"
    if isinstance(err, FileNotFoundError):
        return "no such file"
    if isinstance(err, OSError):
        return err.strerror or str(err)
    return str(err)


def whole_number(value: object, what: str) -> int:
    """``value`` as an int if it is a whole number (``3`` or ``3.0``); ValueError naming ``what`` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ValueError(f"{what} {value!r} is not a whole number")
    try:
        number = float(value)
    except ValueError:
        raise ValueError(f"{what} {value!r} is not a whole number") from None
    if not number.is_integer():
        raise ValueError(f"{what} {value!r} is not a whole number")
    return int(number)


def check_image_size(source: str, image_size: Sequence[int]) -> tuple[int, int]:
    """(height, width) as ints, InputError unless both are in 1..MAX_IMAGE_SIDE."""
    height, width = image_size
    if not (1 <= height <= MAX_IMAGE_SIDE and 1 <= width <= MAX_IMAGE_SIDE):
        raise InputError(f"{source}: image size {height}x{width} (height x width) is not a real image size")
    return int(height), int(width)


def check_fps(source: str, fps: float) -> float:
    """``fps`` as a float, InputError unless it is a number from MIN_FPS to MAX_FPS."""
    if not MIN_FPS <= fps <= MAX_FPS:  # NaN too
        raise InputError(f"{source}: fps must be a number from {MIN_FPS:g} to {MAX_FPS:g}, got {fps}")
    return float(fps)


def check_frame_numbers(source: str, numbers: Sequence[int], names: Mapping[int, str] | None = None) -> None:
    """InputError when two consecutive frame numbers are more than MAX_GAP_FRAMES apart (naming the file after)."""
    ordered = np.sort(np.asarray(list(numbers), dtype=np.int64))
    if ordered.size < 2:
        return
    gaps = np.diff(ordered)
    if gaps.max() > MAX_GAP_FRAMES:
        at = int(np.argmax(gaps))
        after = int(ordered[at + 1])
        where = f"{names[after]} (frame {after})" if names and after in names else f"frame {after}"
        raise InputError(
            f"{source}: {where} comes {int(gaps[at])} frames after frame {int(ordered[at])}, the one before it "
            f"(more than {MAX_GAP_FRAMES} frames: a mis-numbered file?)"
        )


def check_frame_span(source: str, first: int, last: int, most_people: int) -> None:
    """InputError when frames ``first`` to ``last`` are more than ``MAX_SPAN_FRAMES``, or with ``most_people`` in a
    frame more than ``MAX_PERSON_FRAMES`` person-frames (the dense tracks' memory), before anything is allocated."""
    span = last - first + 1
    if span > MAX_SPAN_FRAMES:
        raise InputError(
            f"{source}: frames {first} to {last} span {span} frames; at most {MAX_SPAN_FRAMES} are supported "
            "(mis-numbered files?)"
        )
    if span * max(most_people, 1) > MAX_PERSON_FRAMES:
        raise InputError(
            f"{source}: {span} frames with up to {most_people} people in one frame are {span * most_people} "
            f"person-frames; at most {MAX_PERSON_FRAMES} are supported (split the take, or lift fewer people)"
        )


def check_people_count(source: str, frame: int, count: int) -> None:
    """InputError when one frame holds more than MAX_PEOPLE people."""
    if count > MAX_PEOPLE:
        raise InputError(f"{source}: frame {frame} has {count} people; at most {MAX_PEOPLE} per frame are supported")


def check_points(source: str, points: np.ndarray, image_size: tuple[int, int], where: str = "") -> None:
    """InputError when a point (..., 3) with confidence above 0 is not finite or lies far outside the image."""
    height, width = image_size
    points = np.asarray(points, dtype=np.float64)
    seen = points[..., 2] > 0
    x, y = points[..., 0], points[..., 1]
    with np.errstate(invalid="ignore"):
        inside = (x >= -width) & (x <= 2 * width) & (y >= -height) & (y <= 2 * height)
    bad = seen & ~inside  # NaN coordinates are not inside either
    if bad.any():
        index = tuple(int(i[0]) for i in np.nonzero(bad))
        raise InputError(
            f"{source}: {where}keypoint {index} at ({x[index]:.6g}, {y[index]:.6g}) px lies far outside the "
            f"{width}x{height} image (or is not a number): a broken value or the wrong image size"
        )
    if (points[..., 2] < 0).any() or np.isnan(points[..., 2]).any():
        raise InputError(f"{source}: {where}a confidence is negative or not a number")


def check_tracks(tracks: PoseTrack2D) -> PoseTrack2D:
    """``tracks`` if its image size, frame times and points are plausible; InputError naming its source otherwise."""
    check_image_size(tracks.source, tracks.image_size)
    times = tracks.frame_times
    if times.size == 0:
        raise InputError(f"{tracks.source}: no frames")
    if not np.isfinite(times).all() or (np.diff(times) <= 0).any():
        raise InputError(f"{tracks.source}: frame times must be finite and increasing (two frames share a time?)")
    check_points(tracks.source, tracks.keypoints, tracks.image_size, "")
    return tracks
