"""Qualisys Track Manager calibration export ``.qca.txt`` (XML).

Per ``<camera>``: ``serial`` (name), ``active``, ``model``, ``viewrotation``;
``<fov_video left right top bottom>`` (the sensor pixels the video covers, inclusive);
``<intrinsic>`` in sensor sub-pixel units (1/64 pixel): ``focalLengthU/V``, ``centerPointU/V``,
``radialDistortion1..3``, ``tangentalDistortion1..2``; ``<transform x y z r11..r33>``: the camera
centre in millimetres and a rotation whose rows are the camera's axes in the world, in Qualisys'
camera frame (x right, y up, looking along -z). OpenCV's camera frame flips y and z.

The video image is assumed to be the ``fov_video`` region at one sensor pixel per image pixel (no
binning); ``calib check`` with the videos shows when that is wrong. Distortion coefficients are
read as they are, on normalised coordinates as in OpenCV (see docs/calibration.md for the check).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from platypose.lifting.calibration.defaults import complete_camera
from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.calibration.validate import (
    as_array,
    as_rotation,
    as_size,
    check_cameras,
    check_intrinsics,
    read_xml,
)
from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError

SUBPIXELS = 64.0  # Qualisys sensor coordinates are in 1/64 pixel
# Qualisys camera frame (y up, looking along -z) -> OpenCV's (y down, looking along +z).
FLIP_YZ = np.diag([1.0, -1.0, -1.0])
ROTATION_KEYS = tuple(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
ASSUMED_BINNING = "video assumed to cover the fov_video region one sensor pixel per image pixel (no binning)"


def is_qualisys(path: Path) -> bool:
    """True for a ``.qca.txt`` file, or a ``.txt`` whose first bytes hold a ``<calibration`` XML element."""
    if path.name.lower().endswith(".qca.txt"):
        return True
    if path.suffix.lower() != ".txt" or not path.is_file():
        return False
    with path.open("rb") as handle:
        head = handle.read(512).lstrip()
    return head.startswith(b"<?xml") and b"<calibration" in head


def _numbers(element: ET.Element | None, keys: tuple[str, ...], source: str, where: str) -> np.ndarray:
    """The float attributes ``keys`` of ``element``, else InputError naming what is missing."""
    if element is None:
        raise InputError(f"{source}: {where} is missing")
    missing = [k for k in keys if k not in element.attrib]
    if missing:
        raise InputError(f"{source}: {where} is missing {', '.join(missing)}")
    try:
        values = np.array([float(element.attrib[k]) for k in keys])
    except ValueError:
        raise InputError(f"{source}: {where} has a non-numeric value") from None
    return as_array(values, (len(keys),), source, where)


def _camera(element: ET.Element, source: str) -> Camera:
    """One OpenCV camera, metres, from a ``<camera>`` element."""
    name = element.attrib.get("serial", "").strip()
    if not name:
        raise InputError(f"{source}: a camera has no serial (name)")
    where = f"camera {name!r}"
    if element.attrib.get("viewrotation", "0") not in ("0", "0.0"):
        raise InputError(
            f"{source}: {where} has viewrotation {element.attrib['viewrotation']}; only unrotated views are supported"
        )
    left, right, top, bottom = _numbers(
        element.find("fov_video"), ("left", "right", "top", "bottom"), source, f"{where} fov_video"
    )
    width, height = right - left + 1, bottom - top + 1
    intr = element.find("intrinsic")
    fu, fv, cu, cv = (
        _numbers(intr, ("focalLengthU", "focalLengthV", "centerPointU", "centerPointV"), source, f"{where} intrinsic")
        / SUBPIXELS
    )
    k1, k2, k3, p1, p2 = _numbers(
        intr,
        ("radialDistortion1", "radialDistortion2", "radialDistortion3", "tangentalDistortion1", "tangentalDistortion2"),
        source,
        f"{where} intrinsic",
    )
    K = check_intrinsics([[fu, 0.0, cu - left], [0.0, fv, cv - top], [0.0, 0.0, 1.0]], source, where)
    transform = element.find("transform")
    centre_mm = _numbers(transform, ("x", "y", "z"), source, f"{where} transform")
    rows = as_rotation(
        _numbers(transform, ROTATION_KEYS, source, f"{where} transform").reshape(3, 3), source, f"{where} transform"
    )
    R = FLIP_YZ @ rows
    size = as_size([height, width], source, f"{where} fov_video")
    camera, _ = complete_camera(name, size, K, np.array([k1, k2, p1, p2, k3]), R, -R @ centre_mm)
    return camera


def read_qualisys(path: Path) -> Calibration:
    """Read every active video camera of a Qualisys ``.qca.txt``; millimetres, Z up as QTM's lab frame."""
    source = str(path)
    root = read_xml(path, "Qualisys")
    if root.tag != "calibration" or root.find("cameras") is None:
        raise InputError(f"{source}: not a Qualisys calibration (no <calibration><cameras>)")
    meta = new_meta("qualisys-qca", source, "z", "mm")
    meta["assumptions"].append(ASSUMED_BINNING)
    cameras = []
    for element in root.find("cameras").findall("camera"):
        name = element.attrib.get("serial", "?")
        model = element.attrib.get("model", "none")
        if element.attrib.get("active", "1") != "1":
            meta["assumptions"].append(f"camera {name}: inactive, skipped")
            continue
        if model not in ("none", "") and "video" not in model.lower():
            meta["assumptions"].append(f"camera {name}: marker camera ({model}), skipped")
            continue
        cameras.append(_camera(element, source))
    return Calibration(cameras=check_cameras(cameras, source), meta=meta)
