"""Human3.6M camera parameters as JSON, in the layout VideoPose3D publishes (``common/h36m_dataset.py``).

``{"intrinsics": [{"id", "center", "focal_length", "radial_distortion" [k1 k2 k3],
"tangential_distortion" [p1 p2], "res_w", "res_h"}, ...],
"extrinsics": {"S1": [{"orientation": [w x y z], "translation": [mm]}, ...], ...}}``.
Extrinsics are listed in the order of ``intrinsics``. ``orientation`` is the camera-to-world
quaternion and ``translation`` the camera centre in millimetres, Z up; instead of the
quaternion an entry may give ``R``, the world-to-camera matrix of the original H3.6M metadata.

Human3.6M's tangential distortion is not OpenCV's: it displaces a normalised point by
``(x, y) * (p1 x + p2 y) + (p1, p2) * r^2``. We fit OpenCV's p1 p2 to it by least squares over
the image and record the largest remaining difference in pixels in ``meta``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from platypose.lifting.calibration.defaults import complete_camera
from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.calibration.validate import (
    as_array,
    as_rotation,
    as_size,
    check_cameras,
    check_intrinsics,
    read_json,
)
from platypose.lifting.errors import InputError

INTRINSIC_FIELDS = ("id", "center", "focal_length", "radial_distortion", "tangential_distortion", "res_w", "res_h")


def is_h36m(data: Any) -> bool:
    """True for parsed JSON in the Human3.6M camera layout."""
    return isinstance(data, dict) and isinstance(data.get("intrinsics"), list)


def quaternion_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of a quaternion ``(w, x, y, z)`` (normalised first)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(np.asarray(q, dtype=np.float64)[[1, 2, 3, 0]]).as_matrix()


def _tangential_bases(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Displacement fields (N, 2) per unit p1 and p2, for Human3.6M's model then OpenCV's."""
    r2 = x * x + y * y
    h1 = np.stack([x * x + r2, x * y], axis=-1)
    h2 = np.stack([x * y, y * y + r2], axis=-1)
    o1 = np.stack([2 * x * y, r2 + 2 * y * y], axis=-1)
    o2 = np.stack([r2 + 2 * x * x, 2 * x * y], axis=-1)
    return h1, h2, o1, o2


def fit_opencv_tangential(p: np.ndarray, K: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, float]:
    """OpenCV ``(p1, p2)`` closest to Human3.6M's ``p`` over the image, and the largest remaining error in pixels."""
    height, width = size
    u, v = np.meshgrid(np.linspace(0, width, 41), np.linspace(0, height, 41))
    x = ((u - K[0, 2]) / K[0, 0]).ravel()
    y = ((v - K[1, 2]) / K[1, 1]).ravel()
    h1, h2, o1, o2 = _tangential_bases(x, y)
    scale = np.array([K[0, 0], K[1, 1]])
    target = ((p[0] * h1 + p[1] * h2) * scale).ravel()
    basis = np.stack([(o1 * scale).ravel(), (o2 * scale).ravel()], axis=-1)
    fitted = np.linalg.lstsq(basis, target, rcond=None)[0]
    residual = (basis @ fitted - target).reshape(-1, 2)
    return fitted, float(np.linalg.norm(residual, axis=-1).max())


def _intrinsics(entry: Any, source: str, index: int) -> tuple[str, tuple[int, int], np.ndarray, np.ndarray, float]:
    """Name, (height, width), K, OpenCV dist and the tangential-fit error of one intrinsics entry."""
    if not isinstance(entry, dict) or any(k not in entry for k in INTRINSIC_FIELDS):
        raise InputError(f"{source}: intrinsics entry {index} needs fields {', '.join(INTRINSIC_FIELDS)}")
    name = str(entry["id"])
    f = as_array(entry["focal_length"], (2,), source, f"camera {name} focal_length")
    c = as_array(entry["center"], (2,), source, f"camera {name} center")
    k = as_array(entry["radial_distortion"], (3,), source, f"camera {name} radial_distortion")
    p = as_array(entry["tangential_distortion"], (2,), source, f"camera {name} tangential_distortion")
    size = as_size([entry["res_h"], entry["res_w"]], source, f"camera {name} res_h/res_w")
    K = check_intrinsics([[f[0], 0, c[0]], [0, f[1], c[1]], [0, 0, 1]], source, f"camera {name} focal/center")
    p_cv, error_px = fit_opencv_tangential(p, K, size)
    return name, size, K, np.array([k[0], k[1], p_cv[0], p_cv[1], k[2]]), error_px


def _extrinsics(entry: Any, source: str, name: str) -> tuple[np.ndarray, np.ndarray]:
    """World-to-camera R and t (mm) from a camera-to-world quaternion or an R matrix, and the centre."""
    if not isinstance(entry, dict):
        raise InputError(f"{source}: extrinsics of camera {name} is not a JSON object")
    centre_key = "translation" if "translation" in entry else "T"
    if centre_key not in entry or ("orientation" not in entry and "R" not in entry):
        raise InputError(f"{source}: extrinsics of camera {name} need orientation (or R) and translation (or T)")
    if "orientation" in entry:
        R = quaternion_matrix(as_array(entry["orientation"], (4,), source, f"camera {name} orientation")).T
    else:
        R = as_rotation(entry["R"], source, f"camera {name} R")
    centre = as_array(entry[centre_key], (3,), source, f"camera {name} {centre_key}")
    return R, -R @ centre


def _subject_extrinsics(data: dict, source: str, subject: str | None, count: int) -> tuple[str | None, list | None]:
    """The chosen subject and its list of extrinsics (None when the file has none)."""
    extrinsics = data.get("extrinsics")
    if extrinsics is None:
        return None, None
    if not isinstance(extrinsics, dict):
        raise InputError(f"{source}: extrinsics must map subject names to lists of cameras")
    filled = sorted(s for s, cams in extrinsics.items() if isinstance(cams, list) and all(cams))
    if subject is None:
        if len(filled) != 1:
            raise InputError(
                f"{source}: several subjects; give subject, one with extrinsics: {', '.join(filled)}", option="subject"
            )
        subject = filled[0]
    if subject not in filled:
        raise InputError(f"{source}: subject {subject!r} has no extrinsics (available: {', '.join(filled)})")
    if len(extrinsics[subject]) != count:
        raise InputError(
            f"{source}: subject {subject} lists {len(extrinsics[subject])} cameras, intrinsics list {count}"
        )
    return subject, extrinsics[subject]


def read_h36m(path: Path, subject: str | None = None) -> Calibration:
    """Read a Human3.6M camera JSON for one subject's extrinsics (the only one if ``subject`` is None)."""
    source = str(path)
    data = read_json(path)
    if not is_h36m(data):
        raise InputError(f"{source}: not a Human3.6M camera file (no intrinsics list)")
    subject, extrinsics = _subject_extrinsics(data, source, subject, len(data["intrinsics"]))
    meta = new_meta("h36m-json", source, "z", "mm")
    meta["subject"] = subject
    cameras = []
    for i, entry in enumerate(data["intrinsics"]):
        name, size, K, dist, error_px = _intrinsics(entry, source, i)
        R, t = _extrinsics(extrinsics[i], source, name) if extrinsics is not None else (None, None)
        camera, notes = complete_camera(name, size, K, dist, R, t)
        cameras.append(camera)
        meta["assumptions"].extend(notes)
        meta["conversions"].append(
            f"camera {name}: Human3.6M tangential distortion fitted as OpenCV p1 p2 (max difference {error_px:.3f} px)"
        )
    return Calibration(cameras=check_cameras(cameras, source), meta=meta)
