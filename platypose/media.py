"""The one video reader (PyAV), shared by the detectors (frames to detect on) and the exporters (frames to show).

Frames come upright: the container's display rotation (phones store portrait video as landscape
plus a rotation) is applied, so pixel coordinates are those of the video as players show it.
Times are each frame's own presentation time, in seconds from the first frame, so variable frame
rate video keeps its true timing. One frame is in memory at a time.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import av
import numpy as np
from av.video.reformatter import VideoReformatter

from platypose.lifting.errors import InputError

VIDEO_SUFFIXES: tuple[str, ...] = (".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg")


@dataclass(frozen=True)
class VideoInfo:
    """What the container says: nominal frames per second, upright (height, width), frame count (may be
    an estimate) and the display rotation applied to every frame (degrees, 0-270, as PyAV reports it)."""

    fps: float
    image_size: tuple[int, int]
    frame_count: int
    rotation: int = 0


def _reason(err: Exception) -> str:
    """FFmpeg's reason without the file name it repeats."""
    return str(getattr(err, "strerror", None) or err)


def open_video(path: str | Path) -> av.container.InputContainer:
    """Open a video for reading; InputError naming the file if it is missing, unreadable or has no video."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: video file not found")
    try:
        container = av.open(str(path))
    except (OSError, av.FFmpegError) as err:
        raise InputError(f"{path}: cannot read video ({_reason(err)})") from None
    if not container.streams.video:
        container.close()
        raise InputError(f"{path}: has no video stream")
    return container


_CONVERTERS = threading.local()
_INHERITED: list[VideoReformatter] = []  # a forked process's copies of its parent's converters: never freed (below)


def converted(frame: av.VideoFrame, fmt: str) -> av.VideoFrame:
    """``frame`` in pixel format ``fmt``, converted by this thread's own converter (FFmpeg's swscale).

    PyAV 18.1.1 converts with one converter it keeps per process, running FFmpeg's slice threads. A process forked
    from one that had used it (the recording's watched writer, :mod:`platypose.exporters.watched_writer`) found those
    threads gone and waited for them forever: ``platypose demo`` hung. Each thread of each process makes its own,
    and a forked process keeps the copy of its parent's: freeing it would wait for those threads too.
    """
    if getattr(_CONVERTERS, "pid", None) != os.getpid():
        if hasattr(_CONVERTERS, "converter"):
            _INHERITED.append(_CONVERTERS.converter)
        _CONVERTERS.pid, _CONVERTERS.converter = os.getpid(), VideoReformatter()
    return _CONVERTERS.converter.reformat(frame, format=fmt)


def upright(frame: av.VideoFrame, fmt: str = "bgr24") -> np.ndarray:
    """The frame as an (H, W, 3) uint8 array in ``fmt`` (``bgr24`` or ``rgb24``), turned by its display rotation.

    The colour conversion is FFmpeg's, so the pixels equal what OpenCV's reader gives.
    """
    image = converted(frame, fmt).to_ndarray()
    turns = int(round(getattr(frame, "rotation", 0) / 90.0)) % 4
    return np.ascontiguousarray(np.rot90(image, k=turns)) if turns else image


def iter_timed_frames(
    path: str | Path, stride: int = 1, max_frames: int | None = None, fmt: str = "bgr24"
) -> Iterator[tuple[int, float, np.ndarray]]:
    """Yield ``(frame_index, time_s, upright image)`` for every ``stride``-th frame, one at a time."""
    path = Path(path)
    with open_video(path) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        index = emitted = 0
        start = None
        try:
            for frame in container.decode(stream):
                if max_frames is not None and emitted >= max_frames:
                    break
                time = float(frame.time) if frame.time is not None else index / float(stream.average_rate or 1)
                start = time if start is None else start
                if index % stride == 0:
                    yield index, time - start, upright(frame, fmt)
                    emitted += 1
                index += 1
        except av.FFmpegError as err:
            raise InputError(f"{path}: cannot decode video at frame {index} ({_reason(err)})") from None
    if index == 0:
        raise InputError(f"{path}: no decodable frame (corrupt or unsupported video)")


def iter_frames(path: str | Path, stride: int = 1, max_frames: int | None = None) -> Iterator[tuple[int, np.ndarray]]:
    """Yield ``(frame_index, upright BGR image (H, W, 3) uint8)`` one at a time, every ``stride``-th frame."""
    for index, _, image in iter_timed_frames(path, stride, max_frames):
        yield index, image


def frame_stamps(path: str | Path) -> tuple[np.ndarray, float]:
    """Every frame's presentation stamp (N,) in the video stream's time base, sorted, read from the packets (no
    decoding), and that time base in seconds."""
    with open_video(path) as container:
        stream = container.streams.video[0]
        try:
            stamps = [p.pts for p in container.demux(stream) if p.pts is not None and p.size > 0]
        except av.FFmpegError as err:
            raise InputError(f"{path}: cannot read video packets ({_reason(err)})") from None
        return np.sort(np.asarray(stamps, dtype=np.int64)), float(stream.time_base)


def video_tags(path: str | Path) -> dict[str, str]:
    """The video's metadata tags, its container's and then its video stream's (lens tags such as Apple's
    ``com.apple.quicktime.camera.focal_length.35mm_equivalent`` sit in either)."""
    with open_video(path) as container:
        return {**dict(container.metadata), **dict(container.streams.video[0].metadata)}


def frame_times(path: str | Path) -> np.ndarray:
    """Every frame's presentation time (N,) in seconds from the first frame, read from the packets (no decoding)."""
    stamps, time_base = frame_stamps(path)
    if not len(stamps):
        raise InputError(f"{Path(path)}: no video frames")
    times = stamps.astype(np.float64) * time_base
    return times - times[0]


def video_info(path: str | Path) -> VideoInfo:
    """Nominal fps, upright size, frame count and rotation; InputError if missing, unreadable or without frames."""
    path = Path(path)
    with open_video(path) as container:
        stream = container.streams.video[0]
        rate = stream.average_rate or stream.guessed_rate
        count = stream.frames
        try:
            frame = next(container.decode(stream), None)
        except av.FFmpegError:
            frame = None
    if frame is None:
        raise InputError(f"{path}: no decodable frame (corrupt or unsupported video)")
    if not rate or float(rate) <= 0:
        raise InputError(f"{path}: the video does not state a frame rate")
    rotation = int(round(getattr(frame, "rotation", 0))) % 360
    height, width = upright(frame).shape[:2]
    return VideoInfo(float(rate), (height, width), max(int(count or 0), 0), rotation)
