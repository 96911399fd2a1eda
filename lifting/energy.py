"""Guidance energies: reprojection error over any number of cameras, and structural terms.

Reprojection residuals are measured in normalised image units: pixels times
``2 / width`` of that camera (the convention of Human3.6M's screen
normalisation, so the paper's energy scales keep their meaning), which makes
the guidance scale mean the same for every image size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from lifting.camera import CameraBatch, undistort_normalized
from lifting.skeleton import SYMMETRIC_BONES, bone_vectors

ROBUST_LOSSES = ("l2", "geman-mcclure")


@dataclass(frozen=True)
class Observations:
    """2D evidence for a batch of B windows seen by C cameras.

    ``keypoints`` (C, B, F, 17, 2) pixels, ``normalized`` the same undistorted to
    normalised camera coordinates, ``confidence`` (C, B, F, 17) >= 0 with 0 for
    missing keypoints (whose coordinates are zeroed).
    """

    cameras: CameraBatch
    keypoints: torch.Tensor
    normalized: torch.Tensor
    confidence: torch.Tensor

    @staticmethod
    def from_arrays(
        cameras: CameraBatch, keypoints: np.ndarray, confidence: np.ndarray, dtype: torch.dtype = torch.float32
    ) -> Observations:
        """Build from numpy arrays, zeroing the confidence and coordinates of non-finite keypoints."""
        keypoints = np.asarray(keypoints, dtype=np.float64)
        confidence = np.asarray(confidence, dtype=np.float64)
        finite = np.isfinite(keypoints).all(axis=-1) & np.isfinite(confidence)
        conf = np.where(finite, np.clip(confidence, 0.0, None), 0.0)
        kp = np.where(finite[..., None], keypoints, 0.0)
        K = cameras.K.detach().cpu().numpy().astype(np.float64)
        dist = cameras.dist.detach().cpu().numpy().astype(np.float64)
        normalized = np.stack([undistort_normalized(kp[c], K[c], dist[c]) for c in range(len(K))])
        normalized = np.where(finite[..., None], normalized, 0.0)
        device = cameras.K.device

        def tensor(values: np.ndarray) -> torch.Tensor:
            return torch.as_tensor(values, dtype=dtype, device=device)

        return Observations(cameras, tensor(kp), tensor(normalized), tensor(conf))

    @property
    def pixel_scale(self) -> torch.Tensor:
        """Normalised units per pixel of each camera, ``2 / width``, ``(C,)``."""
        return 2.0 / self.cameras.size[:, 1]


def robust_penalty(squared: torch.Tensor, loss: str, scale: float) -> torch.Tensor:
    """Penalty of squared residuals: ``l2`` is the identity, ``geman-mcclure`` is ``s * c^2 / (s + c^2)``."""
    if loss == "l2":
        return squared
    if loss == "geman-mcclure":
        c2 = scale * scale
        return squared * c2 / (squared + c2)
    raise ValueError(f"unknown robust loss {loss!r}; choose one of {', '.join(ROBUST_LOSSES)}")


def reprojection_energy(
    joints: torch.Tensor, obs: Observations, loss: str = "l2", scale: float = 0.05
) -> torch.Tensor:
    """Per-frame energy ``(B, N, F)`` of world joints ``(B, N, F, 17, 3)`` against the observations.

    Sum over cameras and joints of confidence times the robust penalty of the
    squared residual in normalised image units.
    """
    pixels = obs.cameras.project(joints)  # (C, B, N, F, 17, 2)
    target = obs.keypoints.unsqueeze(2)
    scale_c = obs.pixel_scale.reshape(-1, 1, 1, 1, 1)
    squared = ((pixels - target) ** 2).sum(-1) * scale_c**2
    weighted = obs.confidence.unsqueeze(2) * robust_penalty(squared, loss, scale)
    return weighted.sum(dim=(0, -1))


def robust_slope(squared: torch.Tensor, loss: str, scale: float) -> torch.Tensor:
    """Derivative of :func:`robust_penalty` with respect to the squared residual."""
    if loss == "l2":
        return torch.ones_like(squared)
    c2 = scale * scale
    return (c2 / (squared + c2)) ** 2


def reprojection_terms(
    joints: torch.Tensor, obs: Observations, loss: str = "l2", scale: float = 0.05
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Energy ``(B, N, F)``, gradient ``(B, N, F, 17, 3)`` and Gauss-Newton curvature ``(B, N, F, 17, 3, 3)``.

    Analytic and fused, for guidance: residuals are measured between undistorted
    normalised coordinates and scaled by the focal length into pixels (then into
    normalised image units), which equals :func:`reprojection_energy` up to the
    lens distortion's local stretch.
    """
    cams = obs.cameras
    C = len(cams)
    cam = cams.to_camera_frame(joints)  # (C, B, N, F, 17, 3)
    shape = (C, *([1] * (cam.dim() - 2)))
    z = cam[..., 2:3].clamp(min=1e-3)
    ratio = cam[..., :2] / z
    gain = torch.stack([cams.K[:, 0, 0], cams.K[:, 1, 1]], -1) * obs.pixel_scale[:, None]  # (C, 2) units per unit
    gain = gain.reshape(*shape, 2)
    residual = (ratio - obs.normalized.unsqueeze(2)) * gain  # (C, B, N, F, 17, 2)
    squared = (residual**2).sum(-1)
    conf = obs.confidence.unsqueeze(2)
    energy = (conf * robust_penalty(squared, loss, scale)).sum(dim=(0, -1))
    weight = 2 * conf * robust_slope(squared, loss, scale)  # (C, B, N, F, 17)
    R = cams.R.reshape(*shape, 3, 3)
    jac = (gain / z)[..., None] * (R[..., :2, :] - ratio[..., None] * R[..., 2:3, :])  # (C, ..., 2, 3)
    weighted_jac = weight[..., None, None] * jac
    grad = (weighted_jac.transpose(-1, -2) @ residual.unsqueeze(-1)).squeeze(-1).sum(0)
    curvature = (weighted_jac.transpose(-1, -2) @ jac).sum(0)
    return energy, grad, curvature


def bone_lengths_torch(joints: torch.Tensor) -> torch.Tensor:
    """Bone lengths ``(..., 17, 3) -> (..., 16)``."""
    return bone_vectors(joints).norm(dim=-1)


def bone_constancy_energy(joints: torch.Tensor) -> torch.Tensor:
    """Per-frame squared deviation of bone lengths from their window mean, ``(B, N, F, 17, 3) -> (B, N, F)``, m^2."""
    lengths = bone_lengths_torch(joints)
    return ((lengths - lengths.mean(dim=-2, keepdim=True)) ** 2).sum(-1)


def symmetry_energy(joints: torch.Tensor) -> torch.Tensor:
    """Per-frame squared left/right bone-length difference, ``(B, N, F, 17, 3) -> (B, N, F)``, m^2."""
    lengths = bone_lengths_torch(joints)
    left = lengths[..., [a for a, _ in SYMMETRIC_BONES]]
    right = lengths[..., [b for _, b in SYMMETRIC_BONES]]
    return ((left - right) ** 2).sum(-1)
