"""Segments as lines in the image's normalised coordinates, and how well each points at a vanishing point.

Normalised coordinates: pixels less the image centre (the principal point assumed there), over half the image
diagonal. A vanishing point is a homogeneous 3-vector ``(x, y, w)`` in them (``w = 0``: at infinity); the
vanishing point of a direction ``d`` (3,) in camera coordinates, for a focal length ``f`` in the same units, is
``(f d_x, f d_y, d_z)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from platypose.lifting.calibration.scene.segments import lengths


@dataclass(frozen=True)
class Lines:
    """Segments in normalised coordinates: ``middle`` (N, 2), unit ``direction`` (N, 2), ``length`` (N,) in
    pixels, ``normal`` (N, 3) the unit homogeneous line through each."""

    middle: np.ndarray
    direction: np.ndarray
    length: np.ndarray
    normal: np.ndarray

    def __len__(self) -> int:
        return len(self.length)

    def take(self, index: np.ndarray) -> Lines:
        """The lines at ``index`` (indices or a boolean mask)."""
        return Lines(self.middle[index], self.direction[index], self.length[index], self.normal[index])


def image_scale(size: tuple[int, int]) -> float:
    """Pixels per normalised unit for an image ``size`` (height, width): half its diagonal."""
    return float(np.hypot(*size)) / 2.0


def to_lines(segments: np.ndarray, size: tuple[int, int]) -> Lines:
    """The segments (N, 4) px of an image ``size`` (height, width) as :class:`Lines`."""
    centre = np.array([size[1], size[0]], np.float64) / 2.0
    scale = image_scale(size)
    start = (segments[:, :2] - centre) / scale
    end = (segments[:, 2:] - centre) / scale
    length = lengths(segments)
    direction = (end - start) / np.maximum(length / scale, 1e-12)[:, None]
    ones = np.ones((len(segments), 1))
    normal = np.cross(np.hstack([start, ones]), np.hstack([end, ones]))
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    return Lines((start + end) / 2.0, direction, length, normal)


def misalignment(lines: Lines, points: np.ndarray) -> np.ndarray:
    """Sine of the angle (..., N) between each line and the direction from its middle to each vanishing point
    ``points`` (..., 3); 1 where a point sits on a line's middle."""
    points = np.asarray(points, np.float64)
    return _sine(lines.direction, points[..., None, :2] - points[..., None, 2:3] * lines.middle)


def misalignment_each(lines: Lines, points: np.ndarray) -> np.ndarray:
    """Sine of the angle (N,) between each line and the direction from its middle to its own vanishing point
    ``points`` (N, 3)."""
    return _sine(lines.direction, points[:, :2] - points[:, 2:3] * lines.middle)


def _sine(direction: np.ndarray, towards: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(towards, axis=-1)
    cross = direction[:, 0] * towards[..., 1] - direction[:, 1] * towards[..., 0]
    return np.where(norm > 1e-12, np.abs(cross) / np.maximum(norm, 1e-12), 1.0)


def vanishing_point(direction: np.ndarray, focal: float) -> np.ndarray:
    """The vanishing point(s) (..., 3) of camera-frame direction(s) ``direction`` (..., 3), unit length."""
    point = np.concatenate([focal * direction[..., :2], direction[..., 2:]], axis=-1)
    return point / np.linalg.norm(point, axis=-1, keepdims=True)


def direction_of(point: np.ndarray, focal: float) -> np.ndarray:
    """The camera-frame unit direction (3,) whose vanishing point is ``point`` (3,), signed to point up the image
    (negative y: the world's up for a vertical vanishing point)."""
    d = np.array([point[0] / focal, point[1] / focal, point[2]])
    d /= np.linalg.norm(d)
    return -d if d[1] > 0 else d


def weighted_point(lines: Lines, weights: np.ndarray) -> np.ndarray:
    """The vanishing point (3,) nearest all ``lines`` in weighted least squares (the unit vector minimising
    ``sum w (normal . v)^2``)."""
    scatter = (lines.normal * weights[:, None]).T @ lines.normal
    return np.linalg.eigh(scatter)[1][:, 0]
