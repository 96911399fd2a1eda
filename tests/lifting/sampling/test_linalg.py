"""The small linear algebra of guidance (lifting/sampling/linalg.py) against torch.linalg: packed 3x3 and
block-tridiagonal solves."""

from __future__ import annotations

import pytest
import torch

from platypose.lifting.sampling.linalg import (
    SYMMETRIC_PAIRS,
    add_to_diagonal_,
    solve_block_tridiagonal,
    solve_symmetric3,
)


def test_packed_symmetric_solve_matches_linalg() -> None:
    """The adjugate solve of packed SPD 3x3 systems equals torch.linalg.solve."""
    torch.manual_seed(1)
    a = torch.randn(50, 3, 3, dtype=torch.float64)
    matrices = a @ a.mT + 0.1 * torch.eye(3, dtype=torch.float64)
    rhs = torch.randn(50, 3, dtype=torch.float64)
    packed = torch.stack([matrices[:, k, m] for k, m in SYMMETRIC_PAIRS])
    solution = solve_symmetric3(packed, rhs.T.contiguous())
    assert torch.allclose(solution.T, torch.linalg.solve(matrices, rhs), rtol=1e-10)
    damped = solve_symmetric3(
        add_to_diagonal_(packed.clone(), torch.full((50,), 0.5, dtype=torch.float64)), rhs.T, -2.0
    )
    expected = -2.0 * torch.linalg.solve(matrices + 0.5 * torch.eye(3, dtype=torch.float64), rhs)
    assert torch.allclose(damped.T, expected, rtol=1e-10)


@pytest.mark.parametrize("w", [2, 6])
def test_block_tridiagonal_solve_matches_a_dense_solve(w: int) -> None:
    """Block Cholesky over K blocks equals a dense solve of the assembled matrix (couplings in a w x w corner)."""
    torch.manual_seed(2)
    M, K, n = 4, 5, 6
    dense = torch.zeros(M, K * n, K * n, dtype=torch.float64)
    corner = torch.randn(M, K - 1, w, w, dtype=torch.float64)
    for k in range(K - 1):  # block (k+1, k): top-right corner only
        dense[:, (k + 1) * n : (k + 1) * n + w, (k + 1) * n - w : (k + 1) * n] = corner[:, k]
    dense = dense + dense.mT + 4 * n * torch.eye(K * n, dtype=torch.float64)  # diagonally dominant: SPD
    diag = torch.stack([dense[:, k * n : (k + 1) * n, k * n : (k + 1) * n] for k in range(K)], dim=1)
    rhs = torch.randn(M, K, n, dtype=torch.float64)
    solution = solve_block_tridiagonal(diag, corner, rhs)
    expected = torch.linalg.solve(dense, rhs.reshape(M, K * n, 1)).reshape(M, K, n)
    assert torch.allclose(solution, expected, rtol=1e-10)
