"""OpenCV FileStorage calibration ``.yml``: the EasyMocap pair and single-camera OpenCV files.

EasyMocap: ``intri.yml`` holds ``names`` and per camera ``K_<name>``, ``dist_<name>`` (or ``D_<name>``),
optionally ``H_<name>``/``W_<name>``; ``extri.yml`` holds ``Rot_<name>`` (3x3) or ``R_<name>`` (Rodrigues)
and ``T_<name>``, with ``x_cam = R X + T`` in metres. A single-camera file (OpenCV's calibration sample)
holds ``camera_matrix``, ``distortion_coefficients``, ``image_width``, ``image_height``.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from platypose.lifting.calibration.defaults import SIZE_FROM_CENTRE_NOTE, complete_camera, size_from_principal_point
from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.calibration.validate import (
    as_array,
    as_distortion,
    as_rotation,
    as_size,
    check_cameras,
    check_intrinsics,
)
from platypose.lifting.errors import InputError

INTRI, EXTRI = "intri.yml", "extri.yml"
ASSUMED_FRAME = "world frame not stated by the file: assumed Z up and metres (EasyMocap convention)"


def _open(path: Path) -> cv2.FileStorage:
    """Open a FileStorage for reading, turning OpenCV's parse errors into InputError."""
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError):  # OpenCV's Python binding reports parse errors as either
        raise InputError(f"{path}: not a readable OpenCV FileStorage file (YAML/XML parse error)") from None
    if not fs.isOpened():
        raise InputError(f"{path}: cannot be opened as an OpenCV FileStorage file")
    return fs


def _matrix(fs: cv2.FileStorage, key: str, path: Path) -> np.ndarray | None:
    """The matrix stored under ``key``, or None when absent."""
    node = fs.getNode(key)
    if node.empty():
        return None
    try:
        value = node.mat() if node.isMap() else np.array([node.at(i).real() for i in range(node.size())])
    except (cv2.error, SystemError):
        value = None
    if value is None:
        raise InputError(f"{path}: {key} is not a matrix")
    return value


def _real(fs: cv2.FileStorage, key: str) -> float | None:
    """The number stored under ``key``, or None when absent."""
    node = fs.getNode(key)
    return None if node.empty() else node.real()


def _size(
    height: float | None, width: float | None, K: np.ndarray, path: Path, what: str
) -> tuple[tuple[int, int], bool]:
    """(height, width) from the file, else from the principal point; the flag says it was assumed."""
    if height is not None and width is not None:
        return as_size([height, width], str(path), what), False
    return size_from_principal_point(K), True


def _easymocap_paths(path: Path) -> tuple[Path, Path | None]:
    """The intri.yml and (if present) extri.yml for a folder or either file of the pair."""
    folder = path if path.is_dir() else path.parent
    intri, extri = folder / INTRI, folder / EXTRI
    if not intri.exists():
        raise InputError(f"{path}: EasyMocap calibration needs {INTRI} in {folder}")
    return intri, extri if extri.exists() else None


def is_easymocap(path: Path) -> bool:
    """True for a folder holding intri.yml, or for a file named intri.yml / extri.yml."""
    return (path.is_dir() and (path / INTRI).exists()) or path.name in (INTRI, EXTRI)


def read_easymocap(path: Path) -> Calibration:
    """Read an EasyMocap ``intri.yml`` (+ ``extri.yml`` if present) pair."""
    intri_path, extri_path = _easymocap_paths(path)
    intri = _open(intri_path)
    names_node = intri.getNode("names")
    if names_node.empty() or not names_node.isSeq():
        raise InputError(f"{intri_path}: missing the names list")
    names = [names_node.at(i).string() or str(int(names_node.at(i).real())) for i in range(names_node.size())]
    extri = _open(extri_path) if extri_path is not None else None
    source = str(intri_path.parent)
    meta = new_meta("easymocap-yml", source, "z", "m")
    meta["assumptions"].append(ASSUMED_FRAME)
    cameras = []
    for name in names:
        K_raw = _matrix(intri, f"K_{name}", intri_path)
        if K_raw is None:
            raise InputError(f"{intri_path}: missing K_{name}")
        K = check_intrinsics(K_raw, str(intri_path), f"K_{name}")
        dist_raw = _matrix(intri, f"dist_{name}", intri_path)
        dist_raw = _matrix(intri, f"D_{name}", intri_path) if dist_raw is None else dist_raw
        dist = as_distortion([] if dist_raw is None else dist_raw, str(intri_path), f"dist_{name}")
        size, assumed = _size(_real(intri, f"H_{name}"), _real(intri, f"W_{name}"), K, intri_path, f"camera {name}")
        if assumed:
            meta["assumptions"].append(f"camera {name}: {SIZE_FROM_CENTRE_NOTE}")
        R, t = _easymocap_extrinsics(extri, extri_path, name) if extri is not None else (None, None)
        camera, notes = complete_camera(name, size, K, dist, R, t)
        cameras.append(camera)
        meta["assumptions"].extend(notes)
    return Calibration(cameras=check_cameras(cameras, source), meta=meta)


def _easymocap_extrinsics(extri: cv2.FileStorage, path: Path, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and translation of camera ``name`` from extri.yml (``Rot_`` preferred over Rodrigues ``R_``)."""
    rot = _matrix(extri, f"Rot_{name}", path)
    rot = _matrix(extri, f"R_{name}", path) if rot is None else rot
    T = _matrix(extri, f"T_{name}", path)
    if rot is None or T is None:
        raise InputError(f"{path}: camera {name} needs Rot_{name} (or R_{name}) and T_{name}")
    return as_rotation(rot, str(path), f"rotation of {name}"), as_array(T, (3,), str(path), f"T_{name}")


def read_opencv_single(path: Path) -> Calibration:
    """Read a one-camera OpenCV calibration file (``camera_matrix``, ``distortion_coefficients``, image size)."""
    fs = _open(path)
    K_raw = _matrix(fs, "camera_matrix", path)
    if K_raw is None:
        raise InputError(f"{path}: no camera_matrix (nor EasyMocap names) found")
    K = check_intrinsics(K_raw, str(path), "camera_matrix")
    dist_raw = _matrix(fs, "distortion_coefficients", path)
    dist = as_distortion([] if dist_raw is None else dist_raw, str(path), "distortion_coefficients")
    size, assumed = _size(_real(fs, "image_height"), _real(fs, "image_width"), K, path, "image size")
    meta = new_meta("opencv-yml", str(path), "z", "m")
    if assumed:
        meta["assumptions"].append(SIZE_FROM_CENTRE_NOTE)
    camera, notes = complete_camera(path.stem, size, K, dist, None, None)
    meta["assumptions"].extend(notes)
    return Calibration(cameras=(camera,), meta=meta)


def read_opencv_yml(path: Path) -> Calibration:
    """Read either kind of OpenCV ``.yml`` calibration."""
    return read_easymocap(path) if is_easymocap(path) else read_opencv_single(path)
