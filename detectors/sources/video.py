"""Video input for the detectors: the shared reader (``platypose.media``: upright frames, each frame's own
time) and the lookup of the video a keypoint file was made from."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError
from platypose.media import VIDEO_SUFFIXES, VideoInfo, frame_times, iter_frames, video_info

__all__ = [
    "VIDEO_SUFFIXES",
    "VideoInfo",
    "frame_times",
    "iter_frames",
    "processed_times",
    "sibling_video",
    "timing_from_video",
    "video_info",
]


def processed_times(path: Path, indices: np.ndarray, fps: float) -> np.ndarray:
    """Times (T,) in seconds of the frames ``indices`` of ``path``: each frame's own timestamp (variable
    frame rate kept), or ``index / fps`` if the container's packets do not cover every decoded frame."""
    times = frame_times(path)
    indices = np.asarray(indices, dtype=np.int64)
    if indices.size and indices.max() >= len(times):
        return indices / fps
    return times[indices]


def decoding_shortfall(
    path: str | Path, info: VideoInfo, indices: np.ndarray, stride: int = 1, max_frames: int | None = None
) -> str | None:
    """A warning when fewer frames could be decoded than the container states (a truncated or damaged file).

    ``indices`` are the frame indices that were read (every ``stride``-th); a run stopped by ``max_frames``
    is not short. One frame of slack allows for containers whose count is off by one.
    """
    if info.frame_count <= 0 or (max_frames is not None and len(indices) >= max_frames):
        return None
    decoded = int(indices[-1]) + 1 if len(indices) else 0
    if decoded + stride - 1 >= info.frame_count - 1:
        return None
    return (
        f"{path}: the container states {info.frame_count} frames but only {decoded} could be decoded "
        f"(truncated or damaged file); frames {decoded}-{info.frame_count - 1} are missing from the result"
    )


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
    from platypose.detectors.sources.keypoint_checks import check_fps, check_image_size

    return check_fps(str(path), fps), check_image_size(str(path), (int(image_size[0]), int(image_size[1])))
