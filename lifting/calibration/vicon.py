"""Vicon Nexus / Tracker calibration ``.xcp`` (XML).

``<Cameras>`` holds one ``<Camera>`` per device: ``DEVICEID``, ``NAME`` (often empty), ``TYPE``
(``Vue_VIDEO`` for a video camera, ``Vantage16V``... for a marker camera), ``SENSOR_SIZE`` (width
height, pixels), ``PIXEL_ASPECT_RATIO``; and in ``<KeyFrames>`` one ``<KeyFrame>`` per stretch of
frames (one for fixed cameras): ``FOCAL_LENGTH`` and ``PRINCIPAL_POINT`` in pixels, ``ORIENTATION``
a quaternion ``x y z w`` (real part last), ``POSITION`` the camera centre in millimetres, and
``VICON_RADIAL2 = "Vicon3Parameter cx cy k1 k2 k3"``: a radial polynomial in pixel units about
``(cx, cy)``.

How we read them (docs/calibration.md gives the checks on a real file):

- The quaternion's matrix is world-to-camera (its rows are the camera's x right, y down and z
  forward axes in the world): read so, the cameras of a real 25-camera Nexus file are upright and
  all look into one capture volume; read as camera-to-world, they do not.
- ``VICON_RADIAL2`` is read as Vicon's correction from recorded pixels ``d`` to ideal ones:
  ``u = c + (d - c)(1 + k1 r^2 + k2 r^4 + k3 r^6)``, ``r = |d - c|`` in pixels. OpenCV's model goes
  the other way (ideal -> recorded, normalised coordinates), so we fit its ``k1 k2 k3`` by least
  squares over the image and record the remaining difference in pixels (median, largest) in ``meta``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from platypose.lifting.calibration.defaults import complete_camera
from platypose.lifting.calibration.h36m import quaternion_matrix
from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.calibration.validate import (
    as_array,
    as_size,
    check_cameras,
    check_distortion,
    check_intrinsics,
    read_xml,
)
from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError

DISTORTION_MODEL = "Vicon3Parameter"
GRID_STEPS = 41  # distorted pixels sampled per image side for the distortion fit


def is_vicon(path: Path) -> bool:
    """True for an ``.xcp`` file."""
    return path.suffix.lower() == ".xcp"


def is_video_camera(element: ET.Element) -> bool:
    """True for a video device (``TYPE`` like ``Vue_VIDEO``); marker (MX/Vantage) cameras are not."""
    return "VIDEO" in element.attrib.get("TYPE", "").upper()


def camera_name(element: ET.Element) -> str:
    """``NAME`` when the user gave one, else the ``DEVICEID`` (Nexus leaves ``NAME`` empty by default)."""
    return element.attrib.get("NAME", "").strip() or element.attrib.get("DEVICEID", "").strip()


def _numbers(text: str | None, count: int, source: str, where: str) -> np.ndarray:
    """``count`` space-separated numbers from an attribute value, else InputError."""
    if text is None:
        raise InputError(f"{source}: {where} is missing")
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        raise InputError(f"{source}: {where} has a non-numeric value") from None
    return as_array(values, (count,), source, where)


def vicon_correction(recorded: np.ndarray, radial: np.ndarray) -> np.ndarray:
    """Ideal pixels ``(N, 2)`` from recorded ones under ``VICON_RADIAL2`` values ``(cx, cy, k1, k2, k3)``."""
    offset = recorded - radial[:2]
    r2 = np.sum(offset * offset, axis=-1, keepdims=True)
    return radial[:2] + offset * (1 + radial[2] * r2 + radial[3] * r2**2 + radial[4] * r2**3)


def fit_opencv_radial(radial: np.ndarray, K: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV ``(k1, k2, k3)`` closest to Vicon's correction over the image, and the remaining errors in px (N,)."""
    height, width = size
    u, v = np.meshgrid(np.linspace(0, width, GRID_STEPS), np.linspace(0, height, GRID_STEPS))
    recorded = np.stack([u.ravel(), v.ravel()], axis=-1)
    focal, centre = np.array([K[0, 0], K[1, 1]]), K[:2, 2]
    ideal = (vicon_correction(recorded, radial) - centre) / focal
    target = ((recorded - centre) / focal - ideal) * focal
    r2 = np.sum(ideal * ideal, axis=-1, keepdims=True)
    basis = np.stack([(ideal * r2**p * focal).ravel() for p in (1, 2, 3)], axis=-1)
    fitted = np.linalg.lstsq(basis, target.ravel(), rcond=None)[0]
    residual = (basis @ fitted - target.ravel()).reshape(-1, 2)
    return fitted, np.linalg.norm(residual, axis=-1)


def check_radial(radial: np.ndarray, size: tuple[int, int], source: str, where: str) -> None:
    """InputError unless Vicon's radial correction scales the farthest image corner by 0.1 to 10 (real lenses:
    a few per cent)."""
    height, width = size
    corners = np.array([[0.0, 0.0], [width, 0.0], [0.0, height], [width, height]])
    r2 = float(np.max(np.sum((corners - radial[:2]) ** 2, axis=-1)))
    with np.errstate(all="ignore"):
        factor = 1 + radial[2] * r2 + radial[3] * r2**2 + radial[4] * r2**3
    if not (np.isfinite(factor) and 0.1 < factor < 10) or np.any(np.abs(radial[:2]) > 100 * max(size)):
        raise InputError(
            f"{source}: {where} VICON_RADIAL2 distortion is out of range (scales the image corner by {factor:.3g})"
        )


def vicon_camera(element: ET.Element, source: str) -> tuple[Camera, np.ndarray]:
    """One OpenCV camera (file units, millimetres) from a ``<Camera>`` element, and its distortion-fit errors in px."""
    name = camera_name(element)
    if not name:
        raise InputError(f"{source}: a camera has neither NAME nor DEVICEID")
    where = f"camera {name!r}"
    keyframes = element.findall("KeyFrames/KeyFrame")
    if len(keyframes) != 1:
        raise InputError(
            f"{source}: {where} has {len(keyframes)} KeyFrames; only fixed cameras (one KeyFrame) are supported"
        )
    key = keyframes[0].attrib
    aspect = _numbers(element.attrib.get("PIXEL_ASPECT_RATIO", "1"), 1, source, f"{where} PIXEL_ASPECT_RATIO")[0]
    if aspect != 1.0:
        raise InputError(f"{source}: {where} has PIXEL_ASPECT_RATIO {aspect:g}; only square pixels are supported")
    skew = _numbers(element.attrib.get("SKEW", "0"), 1, source, f"{where} SKEW")[0]
    if skew != 0.0:
        raise InputError(f"{source}: {where} has SKEW {skew:g}; only zero skew is supported")
    width, height = _numbers(element.attrib.get("SENSOR_SIZE"), 2, source, f"{where} SENSOR_SIZE")
    size = as_size([height, width], source, f"{where} SENSOR_SIZE")
    focal = _numbers(key.get("FOCAL_LENGTH"), 1, source, f"{where} FOCAL_LENGTH")[0]
    cx, cy = _numbers(key.get("PRINCIPAL_POINT"), 2, source, f"{where} PRINCIPAL_POINT")
    K = check_intrinsics([[focal, 0.0, cx], [0.0, focal, cy], [0.0, 0.0, 1.0]], source, where)
    model, _, values = (key.get("VICON_RADIAL2") or "").partition(" ")
    if model != DISTORTION_MODEL:
        raise InputError(f"{source}: {where} has no VICON_RADIAL2 {DISTORTION_MODEL} distortion (the supported model)")
    radial = _numbers(values, 5, source, f"{where} VICON_RADIAL2")
    check_radial(radial, size, source, where)
    k, errors_px = fit_opencv_radial(radial, K, size)
    check_distortion(k, source, f"{where} VICON_RADIAL2 (as OpenCV k1 k2 k3)")
    quaternion = _numbers(key.get("ORIENTATION"), 4, source, f"{where} ORIENTATION")
    if abs(np.linalg.norm(quaternion) - 1.0) > 1e-3:
        raise InputError(f"{source}: {where} ORIENTATION is not a unit quaternion")
    R = quaternion_matrix(quaternion[[3, 0, 1, 2]])
    centre_mm = _numbers(key.get("POSITION"), 3, source, f"{where} POSITION")
    camera, _ = complete_camera(name, size, K, np.array([k[0], k[1], 0.0, 0.0, k[2]]), R, -R @ centre_mm)
    return camera, errors_px


def read_vicon(path: Path) -> Calibration:
    """Read every video camera of a Vicon ``.xcp``; millimetres, Z up as Vicon's lab frame."""
    source = str(path)
    root = read_xml(path, "Vicon")
    if root.tag != "Cameras":
        raise InputError(f"{source}: not a Vicon calibration (no <Cameras> root element)")
    meta = new_meta("vicon-xcp", source, "z", "mm")
    cameras, skipped = [], []
    for element in root.findall("Camera"):
        if not is_video_camera(element):
            skipped.append(f"{camera_name(element)} ({element.attrib.get('TYPE', '?')})")
            continue
        camera, errors_px = vicon_camera(element, source)
        meta["conversions"].append(
            f"camera {camera.name}: Vicon radial correction fitted as OpenCV k1 k2 k3, difference over the image "
            f"{np.median(errors_px):.2f} px median, {errors_px.max():.2f} px largest"
        )
        cameras.append(camera)
    if skipped:
        meta["assumptions"].append(f"marker cameras skipped: {', '.join(skipped)}")
    if not cameras:
        raise InputError(f"{source}: no video camera (TYPE ..._VIDEO) in this Vicon calibration")
    return Calibration(cameras=check_cameras(cameras, source), meta=meta)
