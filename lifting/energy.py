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

from lifting.camera import CameraBatch
from lifting.skeleton import SYMMETRIC_BONES, bone_vectors

ROBUST_LOSSES = ("l2", "geman-mcclure")


@dataclass(frozen=True)
class Observations:
    """2D evidence for a batch of B windows seen by C cameras.

    ``keypoints`` (C, B, F, 17, 2) pixels, ``confidence`` (C, B, F, 17) >= 0 with 0
    for missing keypoints (whose pixels may be anything, NaN included).
    """

    cameras: CameraBatch
    keypoints: torch.Tensor
    confidence: torch.Tensor

    @staticmethod
    def from_arrays(
        cameras: CameraBatch, keypoints: np.ndarray, confidence: np.ndarray, dtype: torch.dtype = torch.float32
    ) -> Observations:
        """Build from numpy arrays, zeroing the confidence and pixels of non-finite keypoints."""
        keypoints = np.asarray(keypoints, dtype=np.float64)
        confidence = np.asarray(confidence, dtype=np.float64)
        finite = np.isfinite(keypoints).all(axis=-1) & np.isfinite(confidence)
        conf = np.where(finite, np.clip(confidence, 0.0, None), 0.0)
        kp = np.where(finite[..., None], keypoints, 0.0)
        device = cameras.K.device
        return Observations(
            cameras=cameras,
            keypoints=torch.as_tensor(kp, dtype=dtype, device=device),
            confidence=torch.as_tensor(conf, dtype=dtype, device=device),
        )

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
