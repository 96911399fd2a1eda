"""The floor: a plane in world metres, given (calibration, ``--floor``) or estimated from a lift's foot contacts.

A floor is ``n . x + d = 0`` with ``n`` the unit normal pointing up; ``n . x + d`` is a point's
height above it. Calibrated worlds are Z up with the floor at z = 0 (Pose2Sim, anipose and
mocap systems define them so): ``n = (0, 0, 1)``, ``d = 0``.

Without a calibration (the default camera: level, at the origin) the floor is estimated from a
lift: the stance ankles (the lower ankle of slow frames) of every person's median motion lie on
one plane ``ANKLE_HEIGHT`` above the floor. The camera's pitch is the one that makes the most of
them agree on one height (raised supports, a person standing on a roof, agree among themselves
at any pitch, a walker only at the true one); the floor is the lowest height that a fifth of
them share. Roll is taken as level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError

ANKLE_HEIGHT = 0.1  # metres: an ankle keypoint above the floor, foot flat (bundled mocap 0.07-0.11, shoes add more)
ANKLES = (3, 6)  # right and left ankle (lifting.skeleton order)
STANCE_SPEED = 0.6  # m/s: an ankle slower than this, and the lower one, is taken as standing
MAX_STANCE_POINTS = 1500
FLOOR_SPECS = "auto, none, z=H (a height) or nx,ny,nz,d (a plane n.x + d = 0, n up)"


@dataclass(frozen=True)
class Floor:
    """The plane ``normal . x + offset = 0`` (``normal`` unit, up), and where it came from."""

    normal: tuple[float, float, float]
    offset: float
    source: str

    def height(self, points: np.ndarray) -> np.ndarray:
        """Heights above the floor of points ``(..., 3)``, ``(...)``."""
        return np.asarray(points) @ np.asarray(self.normal) + self.offset

    @property
    def plane(self) -> tuple[float, float, float, float]:
        """``(nx, ny, nz, d)``."""
        return (*self.normal, self.offset)

    def as_dict(self) -> dict:
        """Plain dict for JSON: normal, offset (m), source."""
        return {"normal": list(self.normal), "offset_m": self.offset, "source": self.source}


def plane_floor(nx: float, ny: float, nz: float, d: float, source: str) -> Floor:
    """The floor ``n . x + d = 0`` with ``n`` scaled to unit length; ValueError for a zero normal."""
    normal = np.array([nx, ny, nz], dtype=np.float64)
    length = float(np.linalg.norm(normal))
    if not np.isfinite(length) or length < 1e-9 or not np.isfinite(d):
        raise ValueError(f"floor plane {nx},{ny},{nz},{d}: the normal must be finite and non-zero")
    return Floor(tuple(float(v) for v in normal / length), float(d) / length, source)


def parse_floor(text: str) -> Floor | str | None:
    """A floor specification: "auto" (returned as is), "none" (None), "z=H" or "nx,ny,nz,d"; InputError otherwise."""
    spec = text.strip().lower()
    if spec in ("auto", "none"):
        return None if spec == "none" else "auto"
    try:
        if spec.startswith("z="):
            return plane_floor(0.0, 0.0, 1.0, -float(spec[2:]), "given")
        values = [float(v) for v in spec.split(",")]
        if len(values) == 4:
            return plane_floor(*values, "given")
    except ValueError as err:
        raise InputError(f"floor {text!r}: {err}; use {FLOOR_SPECS}") from None
    raise InputError(f"floor {text!r}: not understood; use {FLOOR_SPECS}")


CALIBRATED_FLOOR = Floor((0.0, 0.0, 1.0), 0.0, "calibration")


def stance_points(joints: np.ndarray, fps: float) -> np.ndarray:
    """Stance ankles ``(M, 3)`` of motions ``(P, T, 17, 3)``: per frame the lower ankle (along world z), if it moves
    slower than ``STANCE_SPEED``; frames with missing joints are skipped."""
    points = []
    for person in joints:
        ankles = person[:, list(ANKLES)]  # (T, 2, 3)
        if len(ankles) < 2:
            continue
        speed = np.linalg.norm(np.gradient(ankles, axis=0), axis=-1) * fps  # (T, 2)
        lower = np.nanargmin(np.where(np.isfinite(ankles[..., 2]), ankles[..., 2], np.inf), axis=1)
        frames = np.arange(len(ankles))
        chosen, chosen_speed = ankles[frames, lower], speed[frames, lower]
        keep = np.isfinite(chosen).all(-1) & (chosen_speed < STANCE_SPEED)
        points.append(chosen[keep])
    return np.concatenate(points) if points else np.zeros((0, 3))


def estimate_floor(
    joints: np.ndarray, camera: Camera, fps: float, pitch_range_deg: float = 40.0
) -> tuple[Floor, dict] | None:
    """The floor under median motions ``(P, T, 17, 3)`` lifted with the level default ``camera`` (see the module),
    and what was found: camera height above it (m), pitch (degrees, positive looking down), stance points used.

    None when fewer than 10 stance frames are found.
    """
    points = stance_points(joints, fps)
    if len(points) < 10:
        return None
    points = points[:: max(1, len(points) // MAX_STANCE_POINTS)]  # the pairwise agreement is quadratic in them
    center = camera.center
    up = np.array([0.0, 0.0, 1.0])
    right = camera.R[0]  # the camera's x axis: pitch turns the world's up about it
    best = None
    for pitch in np.deg2rad(np.arange(-pitch_range_deg, pitch_range_deg + 0.25, 0.25)):
        normal = np.cos(pitch) * up + np.sin(pitch) * np.cross(right, up)
        heights = (points - center) @ normal
        spread = np.abs(heights[:, None] - heights[None, :])
        agreement = np.exp(-0.5 * (spread / 0.03) ** 2).sum()  # pairs of stance points at one height
        if best is None or agreement > best[0]:
            best = (agreement, pitch, normal, heights)
    _, pitch, normal, heights = best
    level = _lowest_shared_height(heights, share=0.2)
    offset = -(center @ normal) - (level - ANKLE_HEIGHT)  # so that stance ankles stand ANKLE_HEIGHT above it
    floor = Floor(tuple(float(v) for v in normal), float(offset), "estimated")
    camera_height = float(floor.height(center))
    down_pitch = float(np.degrees(np.arcsin(np.clip(camera.R[2] @ -np.asarray(normal), -1, 1))))
    info = {"camera_height_m": camera_height, "camera_pitch_deg": down_pitch, "stance_points": int(len(points))}
    return floor, info


def _lowest_shared_height(heights: np.ndarray, share: float, band: float = 0.05) -> float:
    """The lowest height that at least ``share`` of ``heights`` lie within ``band`` of (median of those)."""
    ordered = np.sort(heights)
    need = max(1, int(np.ceil(share * len(ordered))))
    for value in ordered:
        near = ordered[np.abs(ordered - value) <= band]
        if len(near) >= need:
            return float(np.median(near))
    return float(np.median(ordered))
