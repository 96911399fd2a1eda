"""Bring a calibration's world frame to the project's convention: right-handed, Z up, metres."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from platypose.lifting.calibration.model import Calibration, with_note
from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError
from platypose.lifting.rotations import rotation_between

UNIT_METRES: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}
AXES: dict[str, np.ndarray] = {"x": np.eye(3)[0], "y": np.eye(3)[1], "z": np.eye(3)[2]}


def unit_scale(units: str | float, source: str) -> float:
    """Metres per file unit: ``m``, ``cm``, ``mm``, or a positive number (e.g. a board square of 0.04 m)."""
    key = str(units).strip().lower()
    if key in UNIT_METRES:
        return UNIT_METRES[key]
    try:
        scale = float(key)
    except ValueError:
        raise InputError(f"{source}: unknown units {units!r} (use m, cm, mm or metres per unit as a number)") from None
    if not np.isfinite(scale) or scale <= 0:
        raise InputError(f"{source}: units must be a positive number of metres per unit, got {units!r}")
    return scale


def up_vector(up: str, source: str) -> np.ndarray:
    """Unit vector of an axis name ``x``, ``y``, ``z`` with optional sign (``-y``), shape (3,)."""
    key = str(up).strip().lower()
    sign = -1.0 if key.startswith("-") else 1.0
    axis = key.lstrip("+-")
    if axis not in AXES:
        raise InputError(f"{source}: unknown world up axis {up!r} (use x, y, z, -x, -y or -z)")
    return sign * AXES[axis]


def up_rotation(up: np.ndarray) -> np.ndarray:
    """The smallest rotation (3, 3) taking the unit vector ``up`` to +Z (180 degrees about X for -Z)."""
    if float(up @ AXES["z"]) < -1 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    return rotation_between(up, AXES["z"])


def transform_camera(camera: Camera, rotation: np.ndarray, scale: float) -> Camera:
    """The same camera after the world change ``X_new = scale * rotation @ X_old``."""
    return replace(camera, R=camera.R @ rotation.T, t=camera.t * scale)


def to_z_up_metres(
    calibration: Calibration, world_up: str | None = None, units: str | float | None = None
) -> Calibration:
    """Re-express the cameras in a Z-up metre world; ``world_up``/``units`` override what ``meta`` says of the file."""
    meta = calibration.meta
    source = str(meta.get("source", "calibration"))
    up_name = str(world_up if world_up is not None else meta.get("world_up", "z"))
    unit_name = units if units is not None else meta.get("units", "m")
    rotation = up_rotation(up_vector(up_name, source))
    scale = unit_scale(unit_name, source)
    cameras = tuple(transform_camera(c, rotation, scale) for c in calibration.cameras)
    result = replace(calibration, cameras=cameras, meta={**meta, "world_up": "z", "units": "m"})
    if not np.allclose(rotation, np.eye(3)):
        result = with_note(result, "conversions", f"world up axis {up_name} rotated to +z")
    if scale != 1.0:
        result = with_note(result, "conversions", f"units {unit_name} scaled to metres (x{scale:g})")
    return result
