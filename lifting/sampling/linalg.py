"""Small linear algebra shared by guidance, placement and smoothing: many 3x3 systems and banded paths.

- Packed symmetric 3x3 matrices ``(6, ...)`` (entries in ``SYMMETRIC_PAIRS`` order), component-first,
  solved by the adjugate (:func:`solve_symmetric3`).
- Paths over frames: the second-difference (acceleration) operator and the block-tridiagonal
  solve of a per-frame 3x3 system coupled by an acceleration penalty (:func:`solve_smoothed`).
- Rigid motions of component-first points (:func:`rotate_translate`).
"""

from __future__ import annotations

import torch

SYMMETRIC_PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))  # packed 3x3: xx, xy, xz, yy, yz, zz
BLOCK_FRAMES = 8  # frames per block of the block-tridiagonal solve (at least COUPLED_FRAMES)
COUPLED_FRAMES = 2  # accelerations couple each frame with the two before and after it


def unpack_symmetric(packed: torch.Tensor) -> torch.Tensor:
    """Packed 3x3 matrices ``(6, ...)`` in ``SYMMETRIC_PAIRS`` order -> ``(..., 3, 3)``."""
    rows = [[None] * 3 for _ in range(3)]
    for entry, (k, m) in zip(packed, SYMMETRIC_PAIRS):
        rows[k][m] = rows[m][k] = entry
    return torch.stack([torch.stack(row, dim=-1) for row in rows], dim=-2)


def add_to_diagonal_(packed: torch.Tensor, scale: torch.Tensor) -> torch.Tensor:
    """Add ``scale * I`` in place to packed 3x3 matrices ``(6, ...)`` (``SYMMETRIC_PAIRS`` order); ``scale``
    broadcasts against ``(...)``. Returns ``packed``."""
    for entry, (k, m) in zip(packed, SYMMETRIC_PAIRS):
        if k == m:
            entry.add_(scale)
    return packed


def solve_symmetric3(matrix: torch.Tensor, rhs: torch.Tensor, scale: float = 1.0) -> torch.Tensor:
    """``scale`` times the solutions of many symmetric positive definite 3x3 systems, by the adjugate
    (fast on CPU), component-first.

    ``matrix`` ``(6, ...)`` packed in ``SYMMETRIC_PAIRS`` order (xx, xy, xz, yy, yz, zz), ``rhs`` ``(3, ...)``;
    returns ``(3, ...)``. Fused multiply-adds, written in place (about 30 passes over the arrays).
    """
    a, b, c, d, e, f = matrix
    x, y, z = rhs

    def cofactor(p: torch.Tensor, q: torch.Tensor, r: torch.Tensor, s: torch.Tensor) -> torch.Tensor:
        """``p q - r s``, two passes."""
        return torch.mul(p, q).addcmul_(r, s, value=-1)

    A, B, C = cofactor(d, f, e, e), cofactor(c, e, b, f), cofactor(b, e, c, d)
    D, E, F = cofactor(a, f, c, c), cofactor(b, c, a, e), cofactor(a, d, b, b)
    inv_det = torch.mul(a, A).addcmul_(b, B).addcmul_(c, C).reciprocal_()
    if scale != 1.0:
        inv_det.mul_(scale)
    solution = torch.empty_like(rhs)
    for row, (p, q, r) in zip(solution, ((A, B, C), (B, D, E), (C, E, F))):
        torch.mul(p, x, out=row).addcmul_(q, y).addcmul_(r, z).mul_(inv_det)
    return solution


def rotate_translate(
    points: torch.Tensor, rotation: torch.Tensor, translation: torch.Tensor | None = None
) -> torch.Tensor:
    """``rotation @ p + translation`` for component-first points ``(3, ...)`` (one matrix product)."""
    flat = points.reshape(3, -1)
    moved = rotation @ flat if translation is None else torch.addmm(translation[:, None], rotation, flat)
    return moved.reshape(points.shape)


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
