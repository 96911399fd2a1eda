"""Checks on calibration values, each failing with a one-line InputError naming the file and the field."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from platypose.lifting.camera import DIST_TERMS, MAX_TIME_OFFSET_S, Camera
from platypose.lifting.errors import InputError
from platypose.lifting.files.reads import read_regular

ROTATION_TOLERANCE = 1e-5
MAX_CAMERAS = 256  # capture rigs have tens of cameras; more means a damaged or hostile file
# A calibration of the largest supported rig takes well under a megabyte; larger files are refused, counted while
# reading (a FIFO or a growing file has no size to check beforehand).
MAX_CALIBRATION_BYTES = 16 * 2**20


def read_calibration_bytes(path: Path) -> bytes:
    """The bytes of calibration file ``path``: a regular file of at most MAX_CALIBRATION_BYTES, else InputError."""
    return read_regular(path, MAX_CALIBRATION_BYTES, "calibration file")


MAX_IMAGE_SIDE = 65536  # pixels
FOCAL_RANGE_PX = (1.0, 1e6)  # a focal length outside is no lens on any camera we lift from
MAX_DISTORTION = 1000.0  # |k1..k3|, |p1|, |p2| on normalised coordinates; real lenses stay far below


def read_json(path: Path) -> Any:
    """The content of a JSON file, else InputError naming the file."""
    try:
        return json.loads(read_calibration_bytes(path).decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as err:
        raise InputError(f"{path}: not valid JSON ({err})") from None


def read_xml(path: Path, what: str) -> ET.Element:
    """The root element of an XML file, else InputError naming the file (``what``: the tool, for the message)."""
    try:
        return ET.fromstring(read_calibration_bytes(path))
    except ET.ParseError as err:
        raise InputError(f"{path}: not valid {what} XML ({err})") from None


def as_array(value: object, shape: tuple[int, ...], source: str, what: str) -> np.ndarray:
    """``value`` as a finite float64 array of ``shape`` (elements, not nesting, are checked), else InputError."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{source}: {what} is not a numeric array") from None
    except OverflowError:  # a whole number too large for a float (hundreds of digits)
        raise InputError(f"{source}: {what} contains non-finite values") from None
    if arr.size != int(np.prod(shape)):
        raise InputError(f"{source}: {what} has {arr.size} values, expected shape {shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{source}: {what} contains non-finite values")
    return arr.reshape(shape)


def as_rotation(value: object, source: str, what: str) -> np.ndarray:
    """A 3x3 rotation from a matrix (9 values) or a Rodrigues vector (3 values), checked orthonormal with det +1."""
    size = np.asarray(value, dtype=object).size
    if size == 3:
        rvec = as_array(value, (3,), source, what)
        return cv2.Rodrigues(rvec)[0]
    R = as_array(value, (3, 3), source, what)
    if np.abs(R @ R.T - np.eye(3)).max() > ROTATION_TOLERANCE or np.linalg.det(R) < 0:
        raise InputError(f"{source}: {what} is not a rotation matrix (not orthonormal with determinant +1)")
    return R


def as_size(value: object, source: str, what: str) -> tuple[int, int]:
    """Two positive whole pixel counts."""
    arr = as_array(value, (2,), source, what)
    if np.any(arr <= 0) or np.any(arr != np.round(arr)) or np.any(arr > MAX_IMAGE_SIDE):
        raise InputError(
            f"{source}: {what} must be two positive whole pixel counts up to {MAX_IMAGE_SIDE}, got {arr.tolist()}"
        )
    return int(arr[0]), int(arr[1])


def as_distortion(value: object, source: str, what: str) -> np.ndarray:
    """OpenCV distortion ``k1 k2 p1 p2 [k3 [k4 k5 k6]]``: 4, 5 or 8 values (the rational model's k4-k6); more
    (OpenCV's thin-prism and tilt terms) are accepted only if the extra ones are zero."""
    n = np.asarray(value, dtype=object).size
    arr = as_array(value, (n,), source, what)
    kept = n if n in (0, 4, 5, DIST_TERMS) else DIST_TERMS if n > DIST_TERMS else 5  # the rest must be zeros
    if n in (1, 2, 3) or np.any(arr[kept:] != 0):
        raise InputError(f"{source}: {what} has {n} coefficients; supported: k1 k2 p1 p2 [k3 [k4 k5 k6]]")
    check_distortion(arr[:DIST_TERMS], source, what)
    return arr[:DIST_TERMS]


def check_distortion(dist: np.ndarray, source: str, what: str) -> None:
    """InputError when a distortion coefficient is not finite or over ``MAX_DISTORTION`` in size."""
    if not np.all(np.isfinite(dist)) or np.any(np.abs(dist) > MAX_DISTORTION):
        raise InputError(
            f"{source}: {what} distortion {np.asarray(dist).tolist()} is out of range (|k| <= {MAX_DISTORTION:g})"
        )


def check_intrinsics(K: np.ndarray, source: str, what: str) -> np.ndarray:
    """An upper-triangular pinhole matrix with positive focal lengths and last row (0, 0, 1)."""
    K = as_array(K, (3, 3), source, what)
    if K[0, 0] <= 0 or K[1, 1] <= 0:
        raise InputError(f"{source}: {what} has a non-positive focal length")
    low, high = FOCAL_RANGE_PX
    if not (low <= K[0, 0] <= high and low <= K[1, 1] <= high) or np.any(np.abs(K[:2, 2]) > 100 * MAX_IMAGE_SIDE):
        raise InputError(
            f"{source}: {what} focal length {K[0, 0]:.4g}, {K[1, 1]:.4g} px or principal point out of range "
            f"(focal {low:g}-{high:g} px)"
        )
    if not np.allclose(K[2], [0.0, 0.0, 1.0]) or K[1, 0] != 0:
        raise InputError(f"{source}: {what} is not a pinhole camera matrix (expected [[fx,s,cx],[0,fy,cy],[0,0,1]])")
    return K


def check_camera_count(count: int, source: str) -> None:
    """At least one camera and at most ``MAX_CAMERAS``, else InputError naming the file."""
    if count == 0:
        raise InputError(f"{source}: no cameras found")
    if count > MAX_CAMERAS:
        raise InputError(f"{source}: {count} cameras; at most {MAX_CAMERAS} are supported")


def check_cameras(cameras: Sequence[Camera], source: str) -> tuple[Camera, ...]:
    """At least one camera and at most ``MAX_CAMERAS``, unique names, distortion and time offsets in range; returns
    them as a tuple."""
    check_camera_count(len(cameras), source)
    for camera in cameras:
        check_distortion(camera.dist, source, f"camera {camera.name!r}")
        if not abs(camera.time_offset_s) <= MAX_TIME_OFFSET_S:  # NaN fails too
            raise InputError(
                f"{source}: camera {camera.name!r} time_offset_s {camera.time_offset_s:g} is out of range "
                f"(a finite number of seconds, at most {MAX_TIME_OFFSET_S:g} in size, as --sync offsets)"
            )
    counts = Counter(c.name for c in cameras)
    duplicates = sorted(n for n, k in counts.items() if k > 1)
    if duplicates:
        raise InputError(f"{source}: duplicate camera names {duplicates}")
    return tuple(cameras)
