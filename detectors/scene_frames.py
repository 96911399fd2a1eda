"""Grey frames spread over a take, for the camera from the scene's lines
(:func:`platypose.lifting.calibration.scene.estimate.scene_camera`), and the camera from a video.

A short video (up to ``SEQUENTIAL_FRAMES`` frames) is decoded through and every few frames kept; a longer one is
sought to ``count`` times spread over it, keeping the key frame each seek lands on (one decode each, so a long
take costs no more than a short one).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import av
import numpy as np

from platypose.lifting.calibration.lens import PRIOR
from platypose.lifting.calibration.scene.estimate import SceneCamera, scene_camera
from platypose.lifting.calibration.scene.segments import person_boxes
from platypose.lifting.errors import InputError
from platypose.media import frame_stamps, iter_timed_frames, open_video, upright

SAMPLES = 30
SEQUENTIAL_FRAMES = 600


def sample_frames(path: str | Path, count: int = SAMPLES) -> tuple[np.ndarray, list[np.ndarray]]:
    """The indices (K,) and upright grey images (each (H, W) uint8) of up to ``count`` frames spread over the
    video at ``path``."""
    stamps, _ = frame_stamps(path)
    if len(stamps) == 0:
        raise InputError(f"{path}: no video frames")
    if len(stamps) <= SEQUENTIAL_FRAMES:
        stride = max(len(stamps) // count, 1)
        kept = [(index, image) for index, _, image in iter_timed_frames(path, stride=stride, fmt="gray")]
        return np.array([k[0] for k in kept], np.int64), [k[1] for k in kept]
    return _key_frames(path, stamps, count)


def _key_frames(path: str | Path, stamps: np.ndarray, count: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """The key frames at or before ``count`` stamps spread over the video (each once)."""
    indices, images, seen = [], [], set()
    with open_video(path) as container:
        stream = container.streams.video[0]
        for target in np.linspace(0, len(stamps) - 1, count).round().astype(int):
            try:
                container.seek(int(stamps[target]), stream=stream, backward=True, any_frame=False)
                frame = next(container.decode(stream), None)
            except av.FFmpegError as err:
                raise InputError(f"{path}: cannot decode video near frame {target} ({err})") from None
            if frame is None or frame.pts is None or frame.pts in seen:
                continue
            seen.add(frame.pts)
            indices.append(int(np.searchsorted(stamps, frame.pts)))
            images.append(upright(frame, "gray"))
    if not images:
        raise InputError(f"{path}: no decodable frame (corrupt or unsupported video)")
    return np.array(indices, np.int64), images


def video_scene_camera(
    path: str | Path,
    keypoints: Sequence[np.ndarray] | None = None,
    focal_px: float | None = None,
    focal_source: str = PRIOR,
    count: int = SAMPLES,
) -> SceneCamera:
    """The camera of the video at ``path`` from its scene's lines, with the people its ``keypoints`` show masked
    out (optional: per frame of the video, each (P, J, 3) x, y, confidence; an array (T, P, J, 3) will do); ``focal_px`` from ``focal_source`` as in
    :func:`scene_camera`."""
    indices, frames = sample_frames(path, count)
    boxes = None
    if keypoints is not None:
        boxes = [person_boxes(keypoints[i]) if i < len(keypoints) else np.zeros((0, 4)) for i in indices]
    return scene_camera(frames, boxes, focal_px, focal_source)
