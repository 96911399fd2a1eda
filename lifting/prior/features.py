"""Motion windows as network features, and their normalisation.

A window of F frames ``(F, 17, 3)`` becomes ``(F, 51)``: the root (pelvis)
trajectory relative to the window's first frame (3) followed by the 16
root-relative joints (48). The frame is gravity aligned (Z up); heading is
free. Every function here works on numpy arrays and torch tensors alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from platypose.lifting.skeleton import NUM_JOINTS

FEATURES_PER_FRAME = 3 * NUM_JOINTS

Array = np.ndarray | torch.Tensor


def _cat(parts: list[Array], axis: int) -> Array:
    if isinstance(parts[0], torch.Tensor):
        return torch.cat(parts, dim=axis)
    return np.concatenate(parts, axis=axis)


def joints_to_features(joints: Array) -> Array:
    """World joints ``(..., F, 17, 3)`` -> features ``(..., F, 51)``."""
    root = joints[..., 0, :]
    trajectory = root - root[..., :1, :]
    relative = joints[..., 1:, :] - root[..., None, :]
    flat = relative.reshape(*relative.shape[:-2], 3 * (NUM_JOINTS - 1))
    return _cat([trajectory, flat], axis=-1)


def features_to_joints(features: Array) -> Array:
    """Features ``(..., F, 51)`` -> joints ``(..., F, 17, 3)`` with the root of frame 0 at the origin."""
    trajectory = features[..., :3]
    relative = features[..., 3:].reshape(*features.shape[:-1], NUM_JOINTS - 1, 3)
    root = trajectory[..., None, :]
    return _cat([root, relative + root], axis=-2)


@dataclass(frozen=True)
class Normalizer:
    """Per-feature mean and standard deviation ``(51,)`` of training windows."""

    mean: np.ndarray
    std: np.ndarray

    @staticmethod
    def fit(features: np.ndarray, min_std: float = 1e-3) -> Normalizer:
        """Statistics of features ``(..., 51)``."""
        flat = features.reshape(-1, features.shape[-1])
        return Normalizer(mean=flat.mean(axis=0), std=np.maximum(flat.std(axis=0), min_std))

    def normalize(self, features: Array) -> Array:
        """Features -> zero-mean unit-variance network space."""
        mean, std = self._as(features)
        return (features - mean) / std

    def denormalize(self, normalized: Array) -> Array:
        """Network space -> features."""
        mean, std = self._as(normalized)
        return normalized * std + mean

    def _as(self, like: Array) -> tuple[Array, Array]:
        if isinstance(like, torch.Tensor):
            return (
                torch.as_tensor(self.mean, dtype=like.dtype, device=like.device),
                torch.as_tensor(self.std, dtype=like.dtype, device=like.device),
            )
        return self.mean, self.std
