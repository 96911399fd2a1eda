"""Match views (videos, keypoint folders) to calibrated cameras by name, and put view times on one clock."""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError

VIEW_SUFFIXES = ("json", "keypoints", "video")
NUMBERED_CAMERA = re.compile(r"(cam|camera|c|view)\d+")  # normalised names that name a camera by its number
EXTENSIONS = re.compile(r"\.(mp4|avi|mov|mkv|webm|m4v|json|npz|csv|txt)$", re.IGNORECASE)


def normalise_view_name(name: str) -> str:
    """A comparable key: lower case, no extension, no trailing ``_json``-like suffix, no separators, no leading zeros."""
    key = EXTENSIONS.sub("", name.strip().rstrip("/\\").replace("\\", "/").split("/")[-1]).lower()
    key = re.sub(r"[\s_\-.]+", "", key)
    for suffix in VIEW_SUFFIXES:
        if key.endswith(suffix) and len(key) > len(suffix):
            key = key[: -len(suffix)]
    return re.sub(r"\d+", lambda m: str(int(m.group())), key)


def match_views(camera_names: Sequence[str], view_names: Sequence[str], allow_missing: bool = False) -> dict[str, str]:
    """``{camera_name: view_name}``: names must match one to one.

    One camera and one view also pair when their names differ, unless both name a camera by number
    (``cam02`` and ``cam_01``, ``camera3`` and ``c1``): that is another camera's calibration, an error
    naming both. ``allow_missing`` accepts cameras without a view (they are left out of the result);
    an extra view is always an error.
    """
    if len(camera_names) == 1 and len(view_names) == 1:
        camera, view = normalise_view_name(camera_names[0]), normalise_view_name(view_names[0])
        if camera != view and NUMBERED_CAMERA.fullmatch(camera) and NUMBERED_CAMERA.fullmatch(view):
            raise InputError(
                f"view {view_names[0]!r} is another camera than the calibration's only camera {camera_names[0]!r}; "
                f"give that camera's calibration (or rename the camera if it is the same one)"
            )
        return {camera_names[0]: view_names[0]}
    by_key: dict[str, str] = {}
    for view in view_names:
        key = normalise_view_name(view)
        if key in by_key:
            raise InputError(f"views {by_key[key]!r} and {view!r} both match the camera name {key!r}")
        by_key[key] = view
    cameras = {normalise_view_name(c): c for c in camera_names}
    missing = [c for k, c in cameras.items() if k not in by_key]
    extra = [v for k, v in by_key.items() if k not in cameras]
    if missing and not allow_missing:
        raise InputError(f"no view for camera(s) {', '.join(missing)} (views given: {', '.join(view_names)})")
    if extra:
        raise InputError(f"view(s) {', '.join(extra)} match no camera (cameras: {', '.join(camera_names)})")
    return {c: by_key[k] for k, c in cameras.items() if k in by_key}


def common_clock_times(frame_times: np.ndarray, camera: Camera) -> np.ndarray:
    """A view's frame times (T,) in seconds on the shared clock: ``frame_times + camera.time_offset_s``."""
    return np.asarray(frame_times, dtype=np.float64) + camera.time_offset_s


def align_frames(reference_times: np.ndarray, view_times: np.ndarray, tolerance_s: float) -> np.ndarray:
    """For each reference time (T,), the index of the nearest view frame within ``tolerance_s``, else -1."""
    reference = np.asarray(reference_times, dtype=np.float64)
    view_times = np.asarray(view_times, dtype=np.float64)
    if view_times.size == 0:
        return np.full(reference.shape, -1)
    order = np.argsort(view_times)
    ordered = view_times[order]
    right = np.clip(np.searchsorted(ordered, reference), 0, len(ordered) - 1)
    left = np.clip(right - 1, 0, len(ordered) - 1)
    pick = np.where(np.abs(ordered[left] - reference) <= np.abs(ordered[right] - reference), left, right)
    index = order[pick]
    return np.where(np.abs(view_times[index] - reference) <= tolerance_s, index, -1)


def gather_views(
    keypoints: Sequence[np.ndarray], frame_times: Sequence[np.ndarray], cameras: Sequence[Camera], tolerance_s: float
) -> list[np.ndarray]:
    """Put every view on the first view's frames using each camera's ``time_offset_s``.

    ``keypoints[c]`` (T_c, P_c, J, 3) with ``frame_times[c]`` (T_c,); returns per view (T_0, P_c, J, 3)
    with zero confidence where a view has no frame within ``tolerance_s``.
    """
    reference = common_clock_times(frame_times[0], cameras[0])
    gathered = []
    for kp, times, camera in zip(keypoints, frame_times, cameras):
        index = align_frames(reference, common_clock_times(times, camera), tolerance_s)
        view = np.where((index >= 0)[:, None, None, None], np.asarray(kp)[np.maximum(index, 0)], 0.0)
        gathered.append(view)
    return gathered
