"""A camera's pose above a floor in three numbers: pitch, roll and height (the yaw and the place along the floor
are free: the estimated world puts the camera on the z axis looking along +y).

- pitch: degrees the optical axis points below the horizon (positive looking down);
- roll: degrees the image is turned about the optical axis, the angle of the world's up in the image from the
  image's up, positive when up leans to the image's right;
- height: metres of the camera centre above the floor z = 0 (world z up).

The same definitions measure a calibrated camera (:func:`pose_of`) and build an estimated one
(:func:`posed_camera`), so the two compare directly.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.calibration.defaults import LEVEL_R
from platypose.lifting.camera import Camera


def rotation(pitch_deg: float, roll_deg: float) -> np.ndarray:
    """World->camera rotation (3, 3) of a camera looking along +y, pitched down and rolled as given."""
    p, r = np.radians(pitch_deg), np.radians(roll_deg)
    pitch = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(p), -np.sin(p)], [0.0, np.sin(p), np.cos(p)]])
    # roll turns the image: world up, at the image's up for roll 0, leans to the image's right for roll > 0
    roll = np.array([[np.cos(r), -np.sin(r), 0.0], [np.sin(r), np.cos(r), 0.0], [0.0, 0.0, 1.0]])
    return roll @ pitch @ LEVEL_R


def intrinsics(focal_px: float, size: tuple[int, int]) -> np.ndarray:
    """Camera matrix (3, 3) of focal length ``focal_px`` with the principal point at the middle of ``size`` (h, w)."""
    height, width = size
    return np.array([[focal_px, 0.0, width / 2.0], [0.0, focal_px, height / 2.0], [0.0, 0.0, 1.0]])


def posed_camera(
    name: str, size: tuple[int, int], focal_px: float, pitch_deg: float, roll_deg: float, height_m: float
) -> Camera:
    """The camera at ``(0, 0, height_m)`` looking along +y, pitched and rolled, with a centred principal point."""
    R = rotation(pitch_deg, roll_deg)
    return Camera(name=name, size=size, K=intrinsics(focal_px, size), R=R, t=-R @ np.array([0.0, 0.0, height_m]))


def pitched(pitch_deg: float, sd_deg: float | None = None) -> str:
    """Words for a camera's pitch (positive: looking down), as the log says it: "pitched 2.4 degrees up" rather than
    "pitched -2.4 degrees down"; with its spread ``sd_deg`` when given."""
    spread = "" if sd_deg is None else f" +- {sd_deg:.1f}"
    return f"pitched {abs(pitch_deg):.1f}{spread} degrees {'down' if pitch_deg >= 0 else 'up'}"


def pitch_roll(up: np.ndarray) -> tuple[float, float]:
    """Pitch and roll (degrees) of a camera that sees the world's up as the unit vector ``up`` (3,) in its own
    coordinates (image up is -y)."""
    return float(np.degrees(np.arcsin(np.clip(-up[2], -1.0, 1.0)))), float(np.degrees(np.arctan2(up[0], -up[1])))


def pose_of(camera: Camera, floor_z: float = 0.0) -> dict[str, float]:
    """Pitch and roll (degrees), height above the level floor at ``floor_z`` (m) and focal length (px, the mean
    of fx and fy) of ``camera`` in a z-up world."""
    pitch, roll = pitch_roll(camera.R @ np.array([0.0, 0.0, 1.0]))
    return {
        "pitch_deg": pitch,
        "roll_deg": roll,
        "height_m": float(camera.center[2] - floor_z),
        "focal_px": float((camera.K[0, 0] + camera.K[1, 1]) / 2.0),
    }
