"""Noise schedule, respacing and DDIM re-noising (knows nothing of the network).

Training uses a cosine schedule with ``T = 50`` steps. Sampling keeps
``n`` steps ``floor(linspace(0, T - 1, n))`` ("ddimN" respacing), skips the
first ``S`` of them and re-noises deterministically (DDIM, eta = 0), or with the
second-order multistep DPM-Solver++(2M), which also uses the previous step's
prediction (no extra network call).
"""

from __future__ import annotations

import math

import numpy as np
import torch

TRAIN_STEPS = 50


def cosine_alphas_cumprod(num_steps: int = TRAIN_STEPS, s: float = 0.008, max_beta: float = 0.999) -> np.ndarray:
    """Cumulative signal fraction ``abar_t`` for t = 0 .. T-1 of the cosine schedule (Nichol & Dhariwal), ``(T,)``."""

    def f(t: float) -> float:
        return math.cos((t / num_steps + s) / (1 + s) * math.pi / 2) ** 2

    betas = np.array([min(1 - f(i + 1) / f(i), max_beta) for i in range(num_steps)])
    return np.cumprod(1.0 - betas)


def respaced_steps(num_kept: int, num_steps: int = TRAIN_STEPS) -> np.ndarray:
    """Training steps kept by "ddimN" respacing, ascending, ``(num_kept,)``."""
    if not 1 <= num_kept <= num_steps:
        raise ValueError(f"number of sampling steps must be in 1..{num_steps}, got {num_kept}")
    return np.floor(np.linspace(0, num_steps - 1, num_kept)).astype(int)


def sampling_steps(num_kept: int, skip: int, num_steps: int = TRAIN_STEPS) -> np.ndarray:
    """The training steps visited by the sampler, descending: the kept steps minus the first ``skip`` noisiest.

    ``num_kept = 10, skip = 2`` gives 8 network calls.
    """
    if not 0 <= skip < num_kept:
        raise ValueError(f"skip must be in 0..{num_kept - 1} for {num_kept} steps, got {skip}")
    kept = respaced_steps(num_kept, num_steps)
    return kept[: num_kept - skip][::-1].copy()


class DiffusionSchedule:
    """The forward process and DDIM (eta = 0) re-noising over one cosine schedule."""

    def __init__(self, num_steps: int = TRAIN_STEPS) -> None:
        self.num_steps = num_steps
        self.alphas_cumprod = torch.as_tensor(cosine_alphas_cumprod(num_steps), dtype=torch.float32)

    def _abar(self, t: torch.Tensor | int, like: torch.Tensor) -> torch.Tensor:
        abar = self.alphas_cumprod.to(like.device)[torch.as_tensor(t, device=like.device)]
        return abar.to(like.dtype).reshape(-1, *([1] * (like.dim() - 1))) if abar.dim() else abar.to(like.dtype)

    def add_noise(self, x0: torch.Tensor, t: torch.Tensor | int, noise: torch.Tensor) -> torch.Tensor:
        """Forward process ``sqrt(abar_t) x0 + sqrt(1 - abar_t) noise``; ``t`` is a scalar or one step per batch row."""
        abar = self._abar(t, x0)
        return abar.sqrt() * x0 + (1 - abar).sqrt() * noise

    def ddim_step(
        self,
        x_t: torch.Tensor,
        x0_hat: torch.Tensor,
        t: int,
        t_prev: int | None,
        eta: float = 0.0,
        noise: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """Re-noise the (guided) prediction ``x0_hat`` from step ``t`` to ``t_prev`` (None: the end, returns x0_hat).

        ``eta = 0`` is deterministic DDIM; ``eta > 0`` replaces that share of the
        carried noise by fresh ``noise`` (``eta = 1``: DDPM-like ancestral sampling).
        """
        if t_prev is None:
            return x0_hat
        abar_t = self._abar(t, x_t)
        abar_prev = self._abar(t_prev, x_t)
        eps = (x_t - abar_t.sqrt() * x0_hat) / (1 - abar_t).sqrt()
        sigma = eta * ((1 - abar_prev) / (1 - abar_t) * (1 - abar_t / abar_prev)).clamp(min=0).sqrt()
        carried = (1 - abar_prev - sigma**2).clamp(min=0).sqrt() * eps
        fresh = sigma * noise if noise is not None and eta > 0 else 0.0
        return abar_prev.sqrt() * x0_hat + carried + fresh

    def ddim_prediction(self, x_t: torch.Tensor, x_prev: torch.Tensor, t: torch.Tensor | int, t_prev) -> torch.Tensor:
        """The prediction that DDIM (eta = 0) re-noises from ``x_t`` at ``t`` to exactly ``x_prev`` at ``t_prev``.

        The inverse of :meth:`ddim_step` in its prediction; ``t`` and ``t_prev`` are scalars or one
        step per batch row (``t_prev < t``). A distilled student learns this for two teacher steps.
        """
        abar_t, abar_prev = self._abar(t, x_t), self._abar(t_prev, x_t)
        carried = ((1 - abar_prev) / (1 - abar_t)).sqrt()
        return (x_prev - carried * x_t) / (abar_prev.sqrt() - carried * abar_t.sqrt())

    def _log_snr_half(self, t: int, like: torch.Tensor) -> torch.Tensor:
        """``lambda_t = log(alpha_t / sigma_t)`` (half the log signal-to-noise ratio) at step ``t``."""
        abar = self._abar(t, like)
        return 0.5 * (torch.log(abar) - torch.log1p(-abar))

    def dpm_solver_2m_step(
        self,
        x_t: torch.Tensor,
        x0_hat: torch.Tensor,
        t: int,
        t_prev: int | None,
        x0_before: torch.Tensor | None = None,
        t_before: int | None = None,
    ) -> torch.Tensor:
        """DPM-Solver++(2M) from step ``t`` to ``t_prev`` (None: the end, returns ``x0_hat``), deterministic.

        ``x0_before`` is the (guided) prediction of the step before, made at ``t_before``; without
        it the step is first order, which is DDIM with eta = 0 exactly. The two predictions are
        extrapolated linearly in ``lambda`` (Lu et al. 2022, DPM-Solver++ eq. 2M).
        """
        if t_prev is None:
            return x0_hat
        lam_t, lam_prev = self._log_snr_half(t, x_t), self._log_snr_half(t_prev, x_t)
        h = lam_prev - lam_t
        estimate = x0_hat
        if x0_before is not None and t_before is not None:
            ratio = (lam_t - self._log_snr_half(t_before, x_t)) / h
            estimate = (1 + 0.5 / ratio) * x0_hat - (0.5 / ratio) * x0_before
        abar_t, abar_prev = self._abar(t, x_t), self._abar(t_prev, x_t)
        sigma_ratio = ((1 - abar_prev) / (1 - abar_t)).sqrt()
        return sigma_ratio * x_t + abar_prev.sqrt() * (1 - torch.exp(-h)) * estimate
