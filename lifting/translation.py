"""Closed-form root translation: weighted linear least squares over all cameras' rays.

For a pose ``X`` (joints relative to an unknown offset) find per-frame
offsets ``d_f`` that put every joint on the ray of its 2D keypoint. A camera
row gives two linear equations per keypoint in normalised (undistorted)
coordinates ``(u, v)``: ``(u r3 - r1) . (X + d) + (u t3 - t1) = 0`` and the same
with ``v``, ``r2``, ``t2``. Each equation is weighted by the keypoint's
confidence times ``(2 f / (width z))^2`` so that it approximates the
reprojection energy in normalised image units. A smoothness term on the
offsets' accelerations ``mu * sum_f |d_{f+1} - 2 d_f + d_{f-1}|^2`` couples
frames: ``mu = 0`` gives independent frames, a large ``mu`` a straight-line
path; no path at constant velocity is penalised (a first-difference term
would pull every offset towards standing still).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from lifting.camera import CameraBatch
from lifting.energy import Observations


@dataclass(frozen=True)
class RayConstraints:
    """Linear ray equations ``A (X + d) + b = 0`` with weights.

    ``A`` (C, B, F, 17, 2, 3), ``b`` (C, B, F, 17, 2), ``confidence`` (C, B, F, 17),
    ``focal_scale`` (C,) = ``2 f / width`` that turns algebraic error over depth into normalised image units.
    """

    A: torch.Tensor
    b: torch.Tensor
    confidence: torch.Tensor
    focal_scale: torch.Tensor


def ray_constraints(obs: Observations) -> RayConstraints:
    """Ray equations of every observed keypoint, from its undistorted normalised coordinates."""
    cameras = obs.cameras
    uv = obs.normalized  # (C, B, F, 17, 2)
    C = uv.shape[0]
    R = cameras.R.reshape(C, 1, 1, 1, 3, 3)
    t = cameras.t.reshape(C, 1, 1, 1, 3)
    rows = [uv[..., i, None] * R[..., 2, :] - R[..., i, :] for i in (0, 1)]
    offsets = [uv[..., i] * t[..., 2] - t[..., i] for i in (0, 1)]
    focal = (cameras.K[:, 0, 0] + cameras.K[:, 1, 1]) / 2
    return RayConstraints(
        A=torch.stack(rows, dim=-2), b=torch.stack(offsets, dim=-1), confidence=obs.confidence,
        focal_scale=focal * obs.pixel_scale,
    )  # fmt: skip


def solve_translation(
    joints: torch.Tensor, rays: RayConstraints, cameras: CameraBatch, smoothness: float
) -> torch.Tensor:
    """Offsets ``(B, N, F, 3)`` minimising the weighted ray error of ``joints + d`` (``joints`` (B, N, F, 17, 3)).

    ``smoothness`` is relative: ``mu`` is that many times the mean per-frame data weight.
    Frames or hypotheses without any evidence get a zero offset.
    """
    joints = joints.detach()
    B, N, F = joints.shape[:3]
    depth = cameras.to_camera_frame(joints)[..., 2].clamp(min=0.1)  # (C, B, N, F, 17)
    weight = rays.confidence.unsqueeze(2) * (rays.focal_scale.reshape(-1, 1, 1, 1, 1) / depth) ** 2
    A = rays.A.unsqueeze(2)  # (C, B, 1, F, 17, 2, 3)
    residual = (A @ joints.unsqueeze(0).unsqueeze(-1)).squeeze(-1) + rays.b.unsqueeze(2)  # (C, B, N, F, 17, 2)
    normal = torch.einsum("cbnfj,cbfjri,cbfjrk->bnfik", weight, rays.A, rays.A)  # (B, N, F, 3, 3)
    rhs = -torch.einsum("cbnfj,cbfjri,cbnfjr->bnfi", weight, rays.A, residual)  # (B, N, F, 3)
    eye = torch.eye(3, dtype=joints.dtype, device=joints.device)
    data_scale = normal.diagonal(dim1=-2, dim2=-1).mean(dim=(-1, -2)).clamp(min=1e-9)  # (B, N)
    regulariser = 1e-6 * data_scale[..., None, None, None] * eye
    if smoothness <= 0 or F < 3:
        return torch.linalg.solve(normal + regulariser, rhs.unsqueeze(-1)).squeeze(-1)
    mu = smoothness * data_scale  # (B, N)
    second_difference = torch.zeros(F - 2, F, dtype=joints.dtype, device=joints.device)
    rows = torch.arange(F - 2)
    second_difference[rows, rows] = 1.0
    second_difference[rows, rows + 1] = -2.0
    second_difference[rows, rows + 2] = 1.0
    penalty = second_difference.T @ second_difference  # (F, F): squared accelerations
    system = torch.zeros(B, N, F, 3, F, 3, dtype=joints.dtype, device=joints.device)
    frames = torch.arange(F)
    system[:, :, frames, :, frames, :] = (normal + regulariser).permute(2, 0, 1, 3, 4)
    system = system + mu[..., None, None, None, None] * torch.einsum("fg,ik->figk", penalty, eye)
    # Cholesky (the system is symmetric positive definite): torch's batched LU solve on CPU returns wrong
    # results with several threads for matrices of 160 x 160 and more (pytorch issue 142815).
    factor = torch.linalg.cholesky(system.reshape(B, N, 3 * F, 3 * F))
    solution = torch.cholesky_solve(rhs.reshape(B, N, 3 * F, 1), factor)
    return solution.reshape(B, N, F, 3)
