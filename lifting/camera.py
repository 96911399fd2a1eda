"""The camera model: OpenCV pinhole with k1 k2 p1 p2 k3 (k4 k5 k6: the rational model) distortion.

``x_cam = R @ X_world + t``; ``(x, y) = x_cam[:2] / x_cam[2]``; distortion as in
OpenCV; ``u = fx * x_d + cx``, ``v = fy * y_d + cy``. Projection equals
``cv2.projectPoints`` with the same parameters.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np
import torch

SIZE_TOLERANCE = 0.02  # calibrated vs actual image size: relative difference taken as the same image (with a warning)
MAX_TIME_OFFSET_S = 24 * 3600.0  # a camera's clock offset larger than a day is no clock difference of one take


DIST_TERMS = 8  # OpenCV's k1 k2 p1 p2 k3 k4 k5 k6; a shorter list is padded with zeros
# cv2.undistortPoints' fixed-point iterations (OpenCV's default is 5, too few for a wide lens's corners); a point
# converged to 1e-12 stops early, so a lens without distortion costs nothing more
UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-12)


@dataclass(frozen=True)
class Camera:
    """One calibrated camera. ``size`` is (height, width) in pixels; world units are metres."""

    name: str
    size: tuple[int, int]
    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(DIST_TERMS))
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    t: np.ndarray = field(default_factory=lambda: np.zeros(3))
    time_offset_s: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "K", np.asarray(self.K, dtype=np.float64).reshape(3, 3))
        dist = np.zeros(DIST_TERMS)
        given = np.asarray(self.dist, dtype=np.float64).ravel()
        dist[: min(len(given), DIST_TERMS)] = given[:DIST_TERMS]
        object.__setattr__(self, "dist", dist)
        object.__setattr__(self, "R", np.asarray(self.R, dtype=np.float64).reshape(3, 3))
        object.__setattr__(self, "t", np.asarray(self.t, dtype=np.float64).reshape(3))
        object.__setattr__(self, "size", (int(self.size[0]), int(self.size[1])))

    @property
    def center(self) -> np.ndarray:
        """Camera centre in world coordinates, ``-R^T t``."""
        return -self.R.T @ self.t

    @property
    def width(self) -> int:
        """Image width in pixels."""
        return self.size[1]

    @property
    def height(self) -> int:
        """Image height in pixels."""
        return self.size[0]


CODEC_BLOCK = 16  # video codecs code frames in blocks of 16 pixels (H.264 macroblocks)


def coded_size(pixels: int) -> int:
    """``pixels`` rounded up to the blocks a video codec codes: 1080 -> 1088."""
    return -(-pixels // CODEC_BLOCK) * CODEC_BLOCK


def codec_padded(calibrated: Sequence[int], video: Sequence[int]) -> bool:
    """Whether a calibrated (height, width) differs from the video's only by the codec's padding: each side equal
    or the video's rounded up to a multiple of ``CODEC_BLOCK``. The codec pads right and bottom and the decoder
    crops them, so the visible pixels keep their coordinates: the same image for the intrinsics."""
    return all(c in (v, coded_size(v)) for c, v in zip(calibrated, video))


def written_distortion(dist: np.ndarray) -> np.ndarray:
    """The coefficients a calibration file holds for ``dist``: k1 k2 p1 p2 k3, and the rational model's k4 k5 k6
    only where the camera has them (so the files of cameras without stay as other tools write them)."""
    dist = np.asarray(dist, np.float64)
    return dist if np.any(dist[5:] != 0) else dist[:5]


def _distort(x: np.ndarray | torch.Tensor, y: np.ndarray | torch.Tensor, dist) -> tuple:
    """OpenCV radial-tangential distortion of normalised coordinates, the rational model's denominator included
    (works for numpy and torch)."""
    k1, k2, p1, p2, k3, k4, k5, k6 = (dist[..., i] for i in range(DIST_TERMS))
    r2 = x * x + y * y
    radial = (1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2) / (1 + k4 * r2 + k5 * r2 * r2 + k6 * r2 * r2 * r2)
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return xd, yd


def project(points: np.ndarray, camera: Camera) -> np.ndarray:
    """Project world points ``(..., 3)`` to pixels ``(..., 2)`` with one camera (numpy, float64)."""
    pts = np.asarray(points, dtype=np.float64)
    cam = pts @ camera.R.T + camera.t
    x = cam[..., 0] / cam[..., 2]
    y = cam[..., 1] / cam[..., 2]
    xd, yd = _distort(x, y, camera.dist)
    K = camera.K
    u = K[0, 0] * xd + K[0, 1] * yd + K[0, 2]
    v = K[1, 1] * yd + K[1, 2]
    return np.stack([u, v], axis=-1)


def undistort_normalized(pixels: np.ndarray, K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Pixels ``(..., 2)`` of one camera -> undistorted normalised coordinates ``(..., 2)`` (cv2.undistortPoints)."""
    flat = np.ascontiguousarray(np.reshape(pixels, (-1, 1, 2)), dtype=np.float64)
    if flat.shape[0] == 0:
        return np.zeros(np.shape(pixels))
    return cv2.undistortPoints(flat, K, dist, criteria=UNDISTORT_CRITERIA).reshape(np.shape(pixels))


@dataclass(frozen=True)
class CameraBatch:
    """Several cameras stacked as torch tensors, for batched differentiable projection.

    Shapes: ``K`` (C, 3, 3), ``dist`` (C, 8), ``R`` (C, 3, 3), ``t`` (C, 3), ``size`` (C, 2) as (h, w).
    """

    K: torch.Tensor
    dist: torch.Tensor
    R: torch.Tensor
    t: torch.Tensor
    size: torch.Tensor

    @staticmethod
    def from_cameras(
        cameras: Sequence[Camera], dtype: torch.dtype = torch.float32, device: str | torch.device = "cpu"
    ) -> CameraBatch:
        """Stack cameras into tensors on ``device``."""

        def stack(values: list[np.ndarray]) -> torch.Tensor:
            return torch.as_tensor(np.stack(values), dtype=dtype, device=device)

        return CameraBatch(
            K=stack([c.K for c in cameras]),
            dist=stack([c.dist for c in cameras]),
            R=stack([c.R for c in cameras]),
            t=stack([c.t for c in cameras]),
            size=stack([np.asarray(c.size, dtype=np.float64) for c in cameras]),
        )

    def __len__(self) -> int:
        return self.K.shape[0]

    def to_camera_frame(self, points: torch.Tensor) -> torch.Tensor:
        """World points ``(..., P, 3)`` -> camera coordinates ``(C, ..., P, 3)``."""
        C = len(self)
        extra = points.dim() - 1
        R = self.R.reshape(C, *([1] * (extra - 1)), 3, 3)
        t = self.t.reshape(C, *([1] * extra), 3)
        return points.unsqueeze(0) @ R.transpose(-1, -2) + t

    def project(self, points: torch.Tensor) -> torch.Tensor:
        """Project world points ``(..., P, 3)`` to pixels ``(C, ..., P, 2)`` in every camera (differentiable)."""
        cam = self.to_camera_frame(points)
        return self.project_camera_frame(cam)

    def project_camera_frame(self, cam: torch.Tensor) -> torch.Tensor:
        """Camera-frame points ``(C, ..., 3)`` to pixels ``(C, ..., 2)``."""
        C = len(self)
        shape = (C, *([1] * (cam.dim() - 2)))
        z = cam[..., 2].clamp(min=1e-6)
        x = cam[..., 0] / z
        y = cam[..., 1] / z
        dist = self.dist.reshape(*shape, DIST_TERMS)
        xd, yd = _distort(x, y, dist)
        K = self.K.reshape(*shape, 3, 3)
        u = K[..., 0, 0] * xd + K[..., 0, 1] * yd + K[..., 0, 2]
        v = K[..., 1, 1] * yd + K[..., 1, 2]
        return torch.stack([u, v], dim=-1)
