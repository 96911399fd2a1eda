"""Several cameras: spread the hypotheses by what the 2D noise leaves uncertain.

With two or more views guidance fits every joint to its least-squares position, so all
hypotheses collapse onto one point per joint, and with noisy 2D the truth lies outside
them (the worst calibration there is; docs/results.md). The fit's residuals tell how
noisy the 2D is: with n observed coordinates and p = 3 unknowns per joint seen twice or
more, the unit-weight variance is ``sigma^2 = E / (n - p)`` (E the confidence-weighted
sum of squared residuals). Linearised, the least-squares position of a joint is then
off by a draw of ``N(0, sigma^2 (J^T W J)^-1)``, with ``J^T W J`` the Gauss-Newton
curvature guidance already uses. Each hypothesis is moved by one such draw, so the
hypotheses spread as the true joint is likely to lie around them.

Every hypothesis keeps one standard normal vector per joint for the whole window (and,
drawn from the same seed, for every window), so the spread moves no joint from frame
to frame beyond how the curvature changes with the pose: it adds no jitter.
"""

from __future__ import annotations

import torch

from platypose.lifting.sampling.linalg import unpack_symmetric


def unit_weight_variance(energy: torch.Tensor, confidence: torch.Tensor) -> torch.Tensor:
    """Residual variance ``(B,)`` per coordinate, in normalised image units squared, of each window's fit.

    ``energy`` ``(B, N, F)`` is the confidence-weighted squared residual of every hypothesis (frames
    without a finite energy, such as a track's padding, count as unobserved);
    ``confidence`` ``(C, B, F, 17)``. The median hypothesis' energy is divided by the redundancy:
    two coordinates per observed keypoint less three unknowns per joint seen by two or more
    cameras, summed over the joints seen twice or more (0 where nothing is redundant: one camera).
    """
    seen = (confidence > 0).sum(0)  # (B, F, 17) views per joint
    redundancy = ((2 * seen - 3) * (seen >= 2)).sum(dim=(-1, -2)).to(energy.dtype)  # (B,); one-view joints fit exactly
    fit = torch.nan_to_num(energy, nan=0.0, posinf=0.0).sum(-1).median(dim=1).values  # (B,); padding frames: NaN
    return torch.where(redundancy > 0, fit / redundancy.clamp(min=1), torch.zeros_like(fit))


def noise_spread(
    curvature: torch.Tensor,
    confidence: torch.Tensor,
    draws: torch.Tensor,
    variance: torch.Tensor,
    smoothed: tuple[torch.Tensor, torch.Tensor] | None = None,
) -> torch.Tensor:
    """Offsets ``(B, N, F, 17, 3)`` that spread fitted world joints by their 2D noise, from the fit's packed
    curvature ``2 J^T W J`` ``(6, B, N, F, 17)`` (:func:`lifting.sampling.energy.reprojection_terms`) and the
    observations' ``confidence`` ``(C, B, F, 17)``.

    ``draws`` ``(N, 17, 3)`` are standard normal, one vector per hypothesis and joint. ``variance``
    ``(B,)`` is the 2D noise's, as the least-squares fit's residuals show it (:func:`unit_weight_variance`:
    it holds the views' disagreement, which real detectors keep from frame to frame, not only their
    jitter). After a fit smoothed over frames, ``smoothed`` = (jitter variance ``(B,)``, shrink
    ``(B, F, 17)``): the jitter's part of the variance is shrunk by that factor
    (:func:`lifting.sampling.temporal_fit.posterior_shrink`), the rest (the views' lasting disagreement) is
    not. A joint
    seen by fewer than two cameras (no depth from the views), or every joint of a window
    without redundancy, gets no offset.
    """
    hessian = unpack_symmetric(curvature)  # (B, N, F, 17, 3, 3)
    twice_seen = ((confidence > 0).sum(0) >= 2)[:, None, :, :, None]  # (B, 1, F, 17, 1)
    safe = torch.where(twice_seen[..., None], hessian, torch.eye(3, dtype=hessian.dtype, device=hessian.device))
    factor, info = torch.linalg.cholesky_ex(safe)
    usable = twice_seen & (info == 0)[..., None]
    # L^T x = z gives x ~ N(0, (L L^T)^-1) = N(0, H^-1); the covariance wanted is sigma^2 (J^T W J)^-1 = 2 sigma^2 H^-1
    z = draws.to(hessian)[None, :, None, :, :, None].expand(*hessian.shape[:-1], 1)
    offsets = torch.linalg.solve_triangular(factor.mT, z, upper=True)[..., 0]
    variance = variance[:, None, None]  # (B, 1, 1) -> (B, F, 17) below when smoothed
    if smoothed is not None:
        jitter, shrink = smoothed
        jitter = torch.minimum(jitter[:, None, None], variance)
        variance = variance - jitter + shrink * jitter
    offsets = offsets * (2 * variance).sqrt()[:, None, :, :, None]
    return torch.where(usable, offsets, torch.zeros_like(offsets))
