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

from platypose.lifting.camera import CameraBatch
from platypose.lifting.sampling.energy import Observations
from platypose.lifting.sampling.linalg import solve_smoothed


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
        A=torch.stack(rows, dim=-2),
        b=torch.stack(offsets, dim=-1),
        confidence=obs.confidence,
        focal_scale=focal * obs.pixel_scale,
    )


def solve_translation(
    joints: torch.Tensor, rays: RayConstraints, cameras: CameraBatch, smoothness: float
) -> torch.Tensor:
    """Offsets ``(B, N, F, 3)`` minimising the weighted ray error of ``joints + d`` (``joints`` (B, N, F, 17, 3)).

    ``smoothness`` is relative: ``mu`` is that many times the mean per-frame data weight.
    Frames or hypotheses without any evidence get a zero offset.
    """
    joints = joints.detach()
    F = joints.shape[2]
    C = len(cameras)
    # depth of every joint in every camera: the camera's third row only, one matrix-vector product per camera
    depth = torch.stack([joints @ cameras.R[c, 2] + cameras.t[c, 2] for c in range(C)]).clamp(min=0.1)
    weight = rays.confidence.unsqueeze(2) * (rays.focal_scale.reshape(-1, 1, 1, 1, 1) / depth) ** 2  # (C,B,N,F,17)
    ata = torch.einsum("cbfjri,cbfjrk->cbfjik", rays.A, rays.A)  # (C, B, F, 17, 3, 3): no hypothesis axis yet
    atb = torch.einsum("cbfjri,cbfjr->cbfji", rays.A, rays.b)
    normal = torch.einsum("cbnfj,cbfjik->bnfik", weight, ata)  # (B, N, F, 3, 3)
    weighted_joints = weight.unsqueeze(-1) * joints.unsqueeze(0)  # (C, B, N, F, 17, 3)
    rhs = -torch.einsum("cbnfjk,cbfjik->bnfi", weighted_joints, ata) - torch.einsum("cbnfj,cbfji->bnfi", weight, atb)
    eye = torch.eye(3, dtype=joints.dtype, device=joints.device)
    data_scale = normal.diagonal(dim1=-2, dim2=-1).mean(dim=(-1, -2)).clamp(min=1e-9)  # (B, N)
    normal = normal + 1e-6 * data_scale[..., None, None, None] * eye
    if smoothness <= 0 or F < 3:
        return torch.linalg.solve(normal, rhs.unsqueeze(-1)).squeeze(-1)
    return solve_smoothed(normal, rhs, smoothness * data_scale)
