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
from platypose.lifting.energy import Observations


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


BLOCK_FRAMES = 8  # frames per block of the block-tridiagonal solve (at least COUPLED_FRAMES)
COUPLED_FRAMES = 2  # accelerations couple each frame with the two before and after it


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


def second_difference(values: torch.Tensor, dim: int = 2) -> torch.Tensor:
    """``x(t+1) - 2 x(t) + x(t-1)`` along ``dim`` (one shorter by two there): accelerations per frame squared."""
    frames_first = values.movedim(dim, 0)
    return (frames_first[2:] - 2 * frames_first[1:-1] + frames_first[:-2]).movedim(0, dim)


def acceleration_penalty(frames: int, dtype: torch.dtype, device: torch.device) -> torch.Tensor:
    """``D^T D`` ``(F, F)`` for the second-difference operator ``D``: the sum of squared accelerations."""
    second_difference = torch.zeros(frames - 2, frames, dtype=dtype, device=device)
    rows = torch.arange(frames - 2, device=device)
    second_difference[rows, rows] = 1.0
    second_difference[rows, rows + 1] = -2.0
    second_difference[rows, rows + 2] = 1.0
    return second_difference.T @ second_difference


def solve_smoothed(normal: torch.Tensor, rhs: torch.Tensor, mu: torch.Tensor) -> torch.Tensor:
    """Solve ``(blockdiag(normal) + mu D^T D (x) I3) d = rhs`` for ``normal`` ``(B, N, F, 3, 3)``, ``rhs`` ``(B, N, F, 3)``.

    The system is banded (accelerations couple frames two apart): it is cut into blocks
    of ``BLOCK_FRAMES`` frames, which makes it block-tridiagonal, and solved by block
    Cholesky. Frames padded at the end (identity, no coupling) are dropped. It is solved in
    float64 and returned in ``rhs``'s dtype: frames without evidence leave only a tiny ridge and
    the acceleration penalty (free on straight lines), a condition float32 Cholesky cannot take
    (it failed on windows seen once or never, at smoothness 10).
    """
    dtype = rhs.dtype
    normal, rhs, mu = normal.double(), rhs.double(), mu.double()
    B, N, F = normal.shape[:3]
    size = BLOCK_FRAMES
    blocks = -(-F // size)
    padded = blocks * size
    eye = torch.eye(3, dtype=normal.dtype, device=normal.device)
    normal = torch.cat([normal, eye.expand(B, N, padded - F, 3, 3)], dim=2)
    rhs = torch.cat([rhs, rhs.new_zeros(B, N, padded - F, 3)], dim=2)
    penalty = torch.zeros(padded, padded, dtype=normal.dtype, device=normal.device)
    penalty[:F, :F] = acceleration_penalty(F, normal.dtype, normal.device)
    penalty = torch.kron(penalty, eye).reshape(blocks, 3 * size, blocks, 3 * size)  # frames x axes, per block
    ks = torch.arange(blocks, device=normal.device)
    mu = mu.reshape(B * N, 1, 1, 1)
    diag = mu * penalty[ks, :, ks, :]  # (B*N, K, 3 size, 3 size)
    frame_blocks = diag.view(B * N, blocks, size, 3, size, 3).diagonal(dim1=2, dim2=4)  # (B*N, K, 3, 3, size)
    frame_blocks += normal.reshape(B * N, blocks, size, 3, 3).permute(0, 1, 3, 4, 2)
    band = 3 * COUPLED_FRAMES  # accelerations couple a block's last frames only with the next block's first ones
    corner = mu * penalty[ks[1:], :band, ks[:-1], -band:]
    solution = solve_block_tridiagonal(diag, corner, rhs.reshape(B * N, blocks, 3 * size))
    return solution.reshape(B, N, padded, 3)[:, :, :F].to(dtype)


def solve_block_tridiagonal(diag: torch.Tensor, corner: torch.Tensor, rhs: torch.Tensor) -> torch.Tensor:
    """Solve symmetric positive definite block-tridiagonal systems by block Cholesky.

    ``diag`` ``(M, K, n, n)`` diagonal blocks; the blocks below them (row k+1, column k) are
    zero but for their top-right ``w x w`` corner, ``corner`` ``(M, K-1, w, w)`` (``w <= n``;
    ``w = n`` is any block); ``rhs`` ``(M, K, n)``. Returns ``(M, K, n)``. One pass over the K
    blocks, every operation batched over the M systems; the couplings between blocks stay
    ``w x w`` (the factor's corner solves only them).
    """
    n, w = diag.shape[-1], corner.shape[-1]
    pad = torch.nn.functional.pad  # puts a w-row part at the top (rows, columns: (0, n - w)) or the bottom (n - w, 0)
    factors, couplings, forward = [], [None], []
    for k in range(diag.shape[1]):
        block, right = diag[:, k], rhs[:, k, :, None]
        if k > 0:  # the factor's coupling block, L_{k-1}^-1 lower^T, is zero but for its bottom-left w x w: g
            g = torch.linalg.solve_triangular(factors[-1][:, -w:, -w:], corner[:, k - 1].mT, upper=False)
            block = block - pad(g.mT @ g, (0, n - w, 0, n - w))
            right = right - pad(g.mT @ forward[-1][:, -w:], (0, 0, 0, n - w))
            couplings.append(g)
        factors.append(torch.linalg.cholesky(block))
        forward.append(torch.linalg.solve_triangular(factors[-1], right, upper=False))
    solution = [None] * len(factors)
    for k in reversed(range(len(factors))):
        right = forward[k]
        if k + 1 < len(factors):
            right = right - pad(couplings[k + 1] @ solution[k + 1][:, :w], (0, 0, n - w, 0))
        solution[k] = torch.linalg.solve_triangular(factors[k].mT, right, upper=True)
    return torch.cat(solution, dim=-1).mT.reshape(rhs.shape)
