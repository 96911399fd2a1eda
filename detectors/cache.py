"""Per-frame detections cached in an npz beside the outputs, valid only for the same video, model and settings."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.files.npz_limits import check_npz_sizes

CACHE_VERSION = 2  # 2: detections in the detector's own layout


def cache_key(video: Path, detector_name: str, stride: int, max_frames: int | None) -> str:
    """A JSON string naming everything the detections depend on (the video file's identity, model, settings)."""
    stat = video.stat()
    return json.dumps(
        {
            "version": CACHE_VERSION,
            "video": str(video.resolve()),
            "video_bytes": stat.st_size,
            "video_mtime_ns": stat.st_mtime_ns,
            "detector": detector_name,
            "stride": stride,
            "max_frames": max_frames,
        },
        sort_keys=True,
    )


def read_detections(path: Path) -> tuple[str, list[np.ndarray], np.ndarray]:
    """A detections file -> (its key, per-frame detections (N_t, S, 3) in the detector's layout, frame indices (T,))."""
    check_npz_sizes(path)
    with np.load(path, allow_pickle=False) as data:
        key, counts, flat, indices = str(data["key"]), data["counts"], data["keypoints"], data["frame_indices"]
    return key, (np.split(flat, np.cumsum(counts)[:-1]) if len(counts) else []), indices


class DetectionCache:
    """The cache file ``<folder>/<name>.detections.npz``: ragged detections stored flat with per-frame counts."""

    def __init__(self, folder: Path, name: str) -> None:
        self.path = folder / f"{name}.detections.npz"

    def load(self, key: str) -> tuple[list[np.ndarray], np.ndarray] | None:
        """Cached (per-frame (N_t, S, 3) detections, frame indices), or None if absent, unreadable or stale."""
        try:
            stored_key, detections, indices = read_detections(self.path)
        except (OSError, KeyError, ValueError, EOFError):
            return None
        return (detections, indices) if stored_key == key else None

    def save(self, key: str, detections: list[np.ndarray], indices: np.ndarray) -> None:
        """Write the cache atomically."""
        counts = np.array([len(d) for d in detections], dtype=np.int64)
        flat = np.concatenate(detections) if detections else np.zeros((0, 0, 3), np.float32)
        with atomic_open(self.path) as stream:
            np.savez(stream, key=np.array(key), counts=counts, keypoints=flat, frame_indices=indices)
