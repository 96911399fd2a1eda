"""Detect people in a video, frame by frame in a stream, then track them: ``detect_video``.

Only keypoints are kept (a few kB per frame), never frames, so memory is
bounded for any video length. Per-frame detections can be cached in a file
beside the outputs, in the detector's own keypoint layout (so a change of the
joint recipes never leaves a stale cache); a re-run with the same video, model
and settings reads them back instead of detecting again (mapping to our joints
and tracking always re-run, they are cheap).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from platypose.detectors.cache import DetectionCache, cache_key
from platypose.detectors.keypoints import to_our_joints
from platypose.detectors.models.detector import Detector
from platypose.detectors.sources.video import decoding_shortfall, iter_frames, processed_times, video_info
from platypose.detectors.tracking.tracker import TrackerConfig, track_detections
from platypose.detectors.types import PoseTrack2D

Progress = Callable[[int, int], None]


def detect_frames(
    video: str | Path,
    detector: Detector,
    stride: int = 1,
    max_frames: int | None = None,
    progress: Progress | None = None,
) -> tuple[list[np.ndarray], np.ndarray]:
    """Run ``detector`` on every ``stride``-th frame: per-frame people (N_t, S, 3) in the detector's own
    layout (``detector.layout``), and frame indices (T,).

    ``progress(done, total)`` is called after each frame (total is an estimate from the container).
    """
    info = video_info(video)
    total = -(-info.frame_count // stride) if info.frame_count else 0
    total = min(total, max_frames) if max_frames else total
    detections, indices = [], []
    for index, frame in iter_frames(video, stride=stride, max_frames=max_frames):
        detections.append(np.asarray(detector(frame), dtype=np.float32))
        indices.append(index)
        if progress is not None:
            progress(len(indices), max(total, len(indices)))
    return detections, np.asarray(indices, dtype=np.int64)


def detect_video(
    video: str | Path,
    detector: Detector,
    tracker: TrackerConfig = TrackerConfig(),
    stride: int = 1,
    max_frames: int | None = None,
    progress: Progress | None = None,
    cache_dir: str | Path | None = None,
) -> PoseTrack2D:
    """Detect and track people in ``video`` -> tracks (T, P, 17, 3) at the processed frames' times.

    With ``cache_dir``, detections are read from / written to a cache file there (a damaged one is removed and
    detected again). A damaged cache, and a video that decodes to fewer frames than its container states, get a
    note (``tracks.notes``) saying so.
    """
    video = Path(video)
    info = video_info(video)
    key = cache_key(video, detector.name, stride, max_frames)
    cache = DetectionCache(Path(cache_dir), video.stem) if cache_dir is not None else None
    damaged: list[str] = []  # a damaged cache is removed and detected again: said in the tracks' notes
    cached = cache.load(key, damaged.append) if cache is not None else None
    if cached is not None:
        detections, indices = cached
    else:
        detections, indices = detect_frames(video, detector, stride, max_frames, progress)
        if cache is not None:
            cache.save(key, detections, indices)
    ours = [to_our_joints(people, detector.layout) for people in detections]
    times = processed_times(video, indices, info.fps)
    tracks = track_detections(ours, times, info.image_size, f"{video} ({detector.name})", tracker)
    short = decoding_shortfall(video, info, indices, stride, max_frames)
    return replace(tracks, notes=tracks.notes + tuple(damaged) + ((short,) if short else ()))
