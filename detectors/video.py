"""Streaming video decoding with OpenCV: one frame in memory at a time, clear errors for unreadable files."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError

VIDEO_SUFFIXES: tuple[str, ...] = (".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg")


@dataclass(frozen=True)
class VideoInfo:
    """What the container says: frames per second, (height, width) and frame count (may be an estimate)."""

    fps: float
    image_size: tuple[int, int]
    frame_count: int


def _open(path: Path):
    import cv2

    if not path.is_file():
        raise InputError(f"{path}: video file not found")
    capture = cv2.VideoCapture(str(path))
    if not capture.isOpened():
        raise InputError(f"{path}: OpenCV cannot open this file as a video")
    return capture


def video_info(path: str | Path) -> VideoInfo:
    """Read fps, size and frame count of a video; InputError if it is missing, unreadable or has no frames."""
    import cv2

    path = Path(path)
    capture = _open(path)
    try:
        fps = capture.get(cv2.CAP_PROP_FPS)
        count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
        ok, frame = capture.read()  # the decoded frame's size, after any rotation OpenCV applies
    finally:
        capture.release()
    if not ok or frame is None or frame.size == 0:
        raise InputError(f"{path}: no decodable frame (corrupt or unsupported video)")
    height, width = frame.shape[:2]
    if not np.isfinite(fps) or fps <= 0:
        raise InputError(f"{path}: the video does not state a frame rate")
    return VideoInfo(float(fps), (height, width), max(count, 0))


def iter_frames(path: str | Path, stride: int = 1, max_frames: int | None = None) -> Iterator[tuple[int, np.ndarray]]:
    """Yield ``(frame_index, BGR image (H, W, 3) uint8)`` one at a time, every ``stride``-th frame."""
    path = Path(path)
    capture = _open(path)
    try:
        index = emitted = 0
        while max_frames is None or emitted < max_frames:
            if index % stride:
                if not capture.grab():
                    break
            else:
                ok, frame = capture.read()
                if not ok:
                    break
                yield index, frame
                emitted += 1
            index += 1
    finally:
        capture.release()
    if index == 0:
        raise InputError(f"{path}: no decodable frame (corrupt or unsupported video)")


def sibling_video(path: Path) -> Path | None:
    """The video a keypoint file or folder was made from: same name less ``_json``, beside it or one up."""
    name = path.name.split(".")[0] if path.is_file() else path.name
    name = name.removesuffix("_json").removesuffix("_keypoints")
    for parent in (path.parent, path.parent.parent):
        for suffix in VIDEO_SUFFIXES:
            if (parent / f"{name}{suffix}").is_file():
                return parent / f"{name}{suffix}"
    return None


def timing_from_video(
    path: Path, fps: float | None, image_size: tuple[int, int] | None
) -> tuple[float, tuple[int, int]]:
    """``fps`` and ``image_size`` for keypoints read from ``path``, missing ones taken from its sibling video."""
    if fps is None or image_size is None:
        video = sibling_video(path)
        if video is None:
            raise InputError(f"{path}: no video beside it to read fps and image size from; pass them")
        info = video_info(video)
        fps = info.fps if fps is None else fps
        image_size = info.image_size if image_size is None else image_size
    if not fps > 0:
        raise InputError(f"{path}: fps must be positive, got {fps}")
    return float(fps), (int(image_size[0]), int(image_size[1]))
