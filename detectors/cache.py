"""Per-frame detections cached in an npz beside the outputs, valid only for the same video, model and settings."""

from __future__ import annotations

import json
import os
import stat
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.files.npz_limits import check_npz_sizes

CACHE_VERSION = 2  # 2: detections in the detector's own layout


def cache_key(video: Path, detector_name: str, stride: int, max_frames: int | None) -> str:
    """A JSON string naming everything the detections depend on (the video file's identity, model, settings)."""
    info = video.stat()
    return json.dumps(
        {
            "version": CACHE_VERSION,
            "video": str(video.resolve()),
            "video_bytes": info.st_size,
            "video_mtime_ns": info.st_mtime_ns,
            "detector": detector_name,
            "stride": stride,
            "max_frames": max_frames,
        },
        sort_keys=True,
    )


def read_detections(path: Path) -> tuple[str, list[np.ndarray], np.ndarray]:
    """A detections file -> (its key, per-frame detections (N_t, S, 3) in the detector's layout, frame indices (T,));
    ValueError for a file that is not one (unreadable, or arrays that do not fit together)."""
    check_npz_sizes(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            key, counts, flat, indices = str(data["key"]), data["counts"], data["keypoints"], data["frame_indices"]
    except zipfile.BadZipFile as err:
        raise ValueError(f"not a readable npz ({err})") from None
    check_layout(counts, flat, indices)
    return key, (np.split(flat, np.cumsum(counts)[:-1]) if len(counts) else []), indices


def check_layout(counts: np.ndarray, flat: np.ndarray, indices: np.ndarray) -> None:
    """ValueError unless ``counts`` (T,) people per frame, ``flat`` (sum of counts, S, 3) and ``indices`` (T,) frame
    indices (increasing) are the arrays of one detections file."""
    if counts.ndim != 1 or indices.shape != counts.shape:
        raise ValueError(f"{counts.shape} counts for {indices.shape} frame indices")
    if len(counts) and not (counts.dtype.kind in "iu" and indices.dtype.kind in "iu"):
        raise ValueError(f"counts and frame indices of types {counts.dtype} and {indices.dtype}, not integers")
    if len(counts) and (counts.min() < 0 or indices.min() < 0 or (np.diff(indices) <= 0).any()):
        raise ValueError("negative counts, or frame indices that are negative or do not increase")
    if flat.ndim != 3 or flat.shape[-1] != 3 or flat.dtype.kind != "f" or len(flat) != counts.sum():
        raise ValueError(f"keypoints of shape {flat.shape} for {counts.sum()} detections (N, S, 3 floats)")


class DetectionCache:
    """The cache file ``<folder>/<name>.detections.npz``: ragged detections stored flat with per-frame counts."""

    def __init__(self, folder: Path, name: str) -> None:
        self.path = folder / f"{name}.detections.npz"

    def load(self, key: str, warn: Callable[[str], None] | None = None) -> tuple[list[np.ndarray], np.ndarray] | None:
        """Cached (per-frame (N_t, S, 3) detections, frame indices), or None if absent, stale or damaged (not a
        regular file, unreadable, arrays that do not fit together: then removed, and ``warn`` told why)."""
        try:
            mode = os.lstat(self.path).st_mode
        except (FileNotFoundError, NotADirectoryError):
            return None
        try:
            if not stat.S_ISREG(mode):
                raise ValueError("not a regular file")
            stored_key, detections, indices = read_detections(self.path)
        except (OSError, KeyError, ValueError, EOFError) as err:
            self._remove(" ".join(str(err).split()) or type(err).__name__, warn)
            return None
        return (detections, indices) if stored_key == key else None

    def _remove(self, why: str, warn: Callable[[str], None] | None) -> None:
        """Remove a damaged cache file (a folder in its place stays: saving then names it), saying ``why``."""
        try:
            self.path.unlink()
        except OSError:
            pass
        if warn is not None:
            warn(f"{self.path}: damaged detection cache ({why}); removed, detected again")

    def save(self, key: str, detections: list[np.ndarray], indices: np.ndarray) -> None:
        """Write the cache atomically."""
        counts = np.array([len(d) for d in detections], dtype=np.int64)
        flat = np.concatenate(detections) if detections else np.zeros((0, 0, 3), np.float32)
        with atomic_open(self.path) as stream:
            np.savez(stream, key=np.array(key), counts=counts, keypoints=flat, frame_indices=indices)
