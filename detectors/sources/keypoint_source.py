"""Pick the reader for a precomputed keypoint source by what it is: folder, npz, CSV or JSON."""

from __future__ import annotations

import json
from pathlib import Path

from platypose.detectors.sources.keypoint_files import read_keypoints_csv, read_keypoints_npz
from platypose.detectors.sources.keypoint_json import FORMAT, read_keypoints_json
from platypose.detectors.sources.mmpose import read_mmpose_json
from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.detectors.tracking.tracker import TrackerConfig
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.errors import InputError

KEYPOINT_SUFFIXES = (".json", ".npz", ".csv")


def view_name(source: Path) -> str:
    """The output / camera-matching name of a view: file stem or folder name without ``_json``."""
    return (source.name if source.is_dir() else source.stem).removesuffix("_json")


def is_keypoint_source(source: Path) -> bool:
    """Whether ``source`` holds precomputed keypoints (a folder or a keypoint file) rather than a video."""
    return source.is_dir() or source.suffix.lower() in KEYPOINT_SUFFIXES


def read_keypoints(
    path: str | Path,
    fps: float | None = None,
    image_size: tuple[int, int] | None = None,
    layout: str | None = None,
    tracker: TrackerConfig = TrackerConfig(),
) -> PoseTrack2D:
    """Read any supported keypoint source: an OpenPose JSON folder, our npz / CSV, minimal-schema or MMPose JSON."""
    path = Path(path)
    if path.is_dir():
        return read_openpose_folder(path, fps, image_size, layout, tracker)
    if not path.is_file():
        raise InputError(f"{path}: no such file or folder")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return read_keypoints_npz(path)
    if suffix == ".csv":
        return read_keypoints_csv(path, image_size)
    if suffix == ".json":
        if _declares_minimal_schema(path):
            return read_keypoints_json(path, tracker)
        return read_mmpose_json(path, fps, image_size, tracker)
    raise InputError(f"{path}: unknown keypoint file type {suffix!r} (expected a folder, .npz, .csv or .json)")


def _declares_minimal_schema(path: Path) -> bool:
    """Whether a JSON file says it follows the minimal schema (unreadable files: no, the other reader reports)."""
    try:
        return json.loads(path.read_text()).get("format") == FORMAT
    except (OSError, ValueError, AttributeError, RecursionError):
        return False
