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

from platypose.detectors.types import PoseTrack2D
from platypose.lifting.calibration.lens import METADATA, PRIOR, metadata_focal
from platypose.lifting.calibration.scene.estimate import FOCAL_HELD_SD, FOCAL_PRIOR_SD, SceneCamera, scene_camera
from platypose.lifting.calibration.scene.segments import person_boxes
from platypose.lifting.calibration.scene.view_camera import AssumedCamera, assumed_camera
from platypose.lifting.errors import InputError
from platypose.media import frame_stamps, iter_timed_frames, open_video, upright, video_tags

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
    times: np.ndarray | None = None,
    focal_sd: float = FOCAL_PRIOR_SD,
) -> SceneCamera:
    """The camera of the video at ``path`` from its scene's lines, with the people its ``keypoints`` show masked
    out (optional: per frame of the video, each (P, J, 3) x, y, confidence; an array (T, P, J, 3) will do);
    ``focal_px`` from ``focal_source`` with its relative spread ``focal_sd`` as in :func:`scene_camera`. ``times``
    (T,): the keypoints' seconds from the video's start where they are not one per frame (each sampled frame takes
    the nearest)."""
    indices, frames = sample_frames(path, count)
    boxes = None
    if keypoints is not None:
        rows = indices if times is None else _nearest(times, _seconds(path, indices))
        boxes = [person_boxes(keypoints[i]) if 0 <= i < len(keypoints) else np.zeros((0, 4)) for i in rows]
    return scene_camera(frames, boxes, focal_px, focal_source, focal_sd)


def view_camera(path: str | Path, name: str, track: PoseTrack2D) -> AssumedCamera:
    """The camera a lift without ``--cams`` assumes for the one video at ``path`` (view ``name``) whose people
    ``track`` holds: the scene's roll and pitch (its people masked) checked against the people's, the focal length
    of the video's metadata and of the lines fused, else the lens prior
    (:func:`platypose.lifting.calibration.scene.view_camera.assumed_camera`)."""
    size = track.image_size
    focal = metadata_focal(video_tags(path), size)
    held = focal is not None
    scene = video_scene_camera(
        path,
        track.keypoints,
        focal,
        METADATA if held else PRIOR,
        times=track.frame_times,
        focal_sd=FOCAL_HELD_SD if held else FOCAL_PRIOR_SD,
    )
    return assumed_camera(name, size, scene, focal, (track.keypoints, track.frame_times))


def _seconds(path: str | Path, indices: np.ndarray) -> np.ndarray:
    """Seconds (K,) from the video's first frame of its frames at ``indices`` (K,)."""
    stamps, time_base = frame_stamps(path)
    return (stamps[indices] - stamps[0]) * time_base


def _nearest(times: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """The index (K,) into sorted ``times`` (T,) nearest each of ``wanted`` (K,); -1 where ``times`` is empty."""
    if len(times) == 0:
        return np.full(len(wanted), -1)
    right = np.clip(np.searchsorted(times, wanted), 0, len(times) - 1)
    left = np.clip(right - 1, 0, len(times) - 1)
    return np.where(np.abs(times[left] - wanted) <= np.abs(times[right] - wanted), left, right)
