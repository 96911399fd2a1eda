"""Synthetic camera rigs for evaluation: a ring of Human3.6M-like cameras around the subject."""

from __future__ import annotations

import numpy as np

from platypose.lifting.camera import Camera


def look_at(position: np.ndarray, target: np.ndarray, up: np.ndarray = np.array([0.0, 0.0, 1.0])) -> np.ndarray:
    """World-to-camera rotation ``R`` (3, 3) of a camera at ``position`` looking at ``target``, image y down."""
    forward = target - position
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, up)
    right = right / np.linalg.norm(right)
    down = np.cross(forward, right)
    return np.stack([right, down, forward])


def ring_cameras(
    count: int = 4,
    radius: float = 5.0,
    height: float = 1.6,
    target: tuple[float, float, float] = (0.0, 0.0, 1.0),
    focal: float = 1145.0,
    size: tuple[int, int] = (1002, 1000),
    first_azimuth_deg: float = 45.0,
) -> list[Camera]:
    """``count`` cameras evenly spaced on a circle around ``target``, like Human3.6M's four (f ~ 1145 px, ~5 m)."""
    cameras = []
    h, w = size
    K = np.array([[focal, 0, w / 2], [0, focal, h / 2], [0, 0, 1.0]])
    for i in range(count):
        azimuth = np.deg2rad(first_azimuth_deg + 360.0 * i / count)
        position = np.array([radius * np.cos(azimuth), radius * np.sin(azimuth), height])
        R = look_at(position, np.asarray(target, dtype=np.float64))
        cameras.append(Camera(name=f"ring{i + 1}", size=size, K=K, R=R, t=-R @ position))
    return cameras
