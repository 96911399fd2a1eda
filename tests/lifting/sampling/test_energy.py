"""The reprojection energy's analytic terms (lifting/sampling/energy.py) against plain references: energy, gradient
and curvature against autograd, one camera's terms in its own axes, and the torch bone lengths."""

from __future__ import annotations

import numpy as np
import torch

from platypose.lifting.camera import CameraBatch
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.sampling.energy import Observations, reprojection_energy, reprojection_terms
from platypose.lifting.sampling.linalg import SYMMETRIC_PAIRS


def _unpack(packed: torch.Tensor) -> torch.Tensor:
    """Packed ``(6, ...)`` -> full symmetric ``(..., 3, 3)``."""
    full = packed.new_zeros(*packed.shape[1:], 3, 3)
    for entry, (k, m) in zip(packed, SYMMETRIC_PAIRS):
        full[..., k, m] = entry
        full[..., m, k] = entry
    return full


def test_reprojection_terms_match_autograd_of_the_energy() -> None:
    """Energy, gradient and Gauss-Newton curvature (J^T W J) equal autograd on the pixel energy (no distortion)."""
    torch.manual_seed(0)
    cams = ring_cameras(3)
    batch = CameraBatch.from_cameras(cams, dtype=torch.float64)
    joints = torch.randn(2, 3, 4, 17, 3, dtype=torch.float64) * 0.3  # (B, N, F, 17, 3) around the rig's centre
    truth = joints[:, 0] + 0.01 * torch.randn(2, 4, 17, 3, dtype=torch.float64)
    pixels = batch.project(truth).numpy()  # (C, B, F, 17, 2)
    confidence = np.random.default_rng(0).uniform(0.2, 1.0, pixels.shape[:-1])
    obs = Observations.from_arrays(batch, pixels, confidence, dtype=torch.float64)
    energy, grad, curvature = reprojection_terms(joints, obs)
    x = joints.clone().requires_grad_(True)
    reference = reprojection_energy(x, obs)
    (reference_grad,) = torch.autograd.grad(reference.sum(), x)
    assert torch.allclose(energy, reference.detach(), rtol=1e-9)
    assert torch.allclose(grad.movedim(0, -1), reference_grad, rtol=1e-7, atol=1e-12)
    # Gauss-Newton curvature of one joint: 2 sum_c conf J^T J of the normalised residuals
    b, n, f, j = 1, 2, 3, 5
    scale = obs.pixel_scale.reshape(-1, 1)

    def residuals(point: torch.Tensor) -> torch.Tensor:
        placed = joints[b, n, f].clone()
        placed[j] = point
        projected = batch.project(placed)[:, j]  # (C, 2)
        return (projected - obs.keypoints[:, b, f, j]) * scale * obs.confidence[:, b, f, j, None].sqrt()

    jac = torch.autograd.functional.jacobian(residuals, joints[b, n, f, j]).reshape(-1, 3)
    assert torch.allclose(_unpack(curvature)[b, n, f, j], 2 * jac.T @ jac, rtol=1e-7)


def test_one_camera_terms_in_its_own_axes_rotate_into_the_world_terms() -> None:
    """With one camera, the cheap camera-frame gradient and curvature are the world ones seen in the camera's axes."""
    torch.manual_seed(3)
    batch = CameraBatch.from_cameras(ring_cameras(4)[2:3], dtype=torch.float64)
    joints = torch.randn(1, 2, 3, 17, 3, dtype=torch.float64) * 0.3
    pixels = batch.project(joints[:, 0] + 0.02).numpy()
    obs = Observations.from_arrays(batch, pixels, np.ones(pixels.shape[:-1]), dtype=torch.float64)
    for loss in ("l2", "geman-mcclure"):
        energy, grad, curvature = reprojection_terms(joints, obs, loss)
        R = batch.R[0]
        energy_c, grad_c, curvature_c = reprojection_terms(joints @ R.T + batch.t[0], obs, loss, in_camera_frame=True)
        assert torch.allclose(energy_c, energy, rtol=1e-12)
        assert torch.allclose(grad_c.movedim(0, -1), grad.movedim(0, -1) @ R.T, rtol=1e-9, atol=1e-12)
        assert torch.allclose(_unpack(curvature_c), R @ _unpack(curvature) @ R.T, rtol=1e-9, atol=1e-9)


def test_torch_bone_lengths_equal_the_skeleton_definition() -> None:
    """The gathered bone lengths follow ``BONES`` (child - parent), as the numpy ``bone_lengths`` does."""
    from platypose.lifting.sampling.energy import bone_lengths_torch
    from platypose.lifting.skeleton import bone_lengths

    joints = np.random.default_rng(2).normal(size=(2, 5, 17, 3))
    assert np.allclose(bone_lengths_torch(torch.as_tensor(joints)).numpy(), bone_lengths(joints), atol=1e-12)
