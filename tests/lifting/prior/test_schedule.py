"""Cosine schedule, ddimN respacing with skip, DDIM re-noising and the DPM-Solver++(2M) step."""

import numpy as np
import torch

from platypose.lifting.prior.schedule import DiffusionSchedule, cosine_alphas_cumprod, respaced_steps, sampling_steps


def test_cosine_schedule_is_monotone_from_clean_to_noise():
    abar = cosine_alphas_cumprod(50)
    assert abar.shape == (50,)
    assert np.all(np.diff(abar) < 0)
    assert abar[0] > 0.99 and abar[-1] < 1e-3


def test_respacing_and_skip_give_paper_step_counts():
    assert respaced_steps(10).tolist() == [0, 5, 10, 16, 21, 27, 32, 38, 43, 49]
    steps = sampling_steps(10, 2)
    assert len(steps) == 8  # T=10, S=2: eight network calls
    assert steps.tolist() == [38, 32, 27, 21, 16, 10, 5, 0]


def test_ddim_step_with_exact_prediction_lands_on_forward_process():
    schedule = DiffusionSchedule()
    x0 = torch.randn(3, 4, 5)
    noise = torch.randn_like(x0)
    x_t = schedule.add_noise(x0, 30, noise)
    x_prev = schedule.ddim_step(x_t, x0, 30, 10)
    assert torch.allclose(x_prev, schedule.add_noise(x0, 10, noise), atol=1e-5)
    assert torch.equal(schedule.ddim_step(x_t, x0, 0, None), x0)


def test_dpm_solver_2m_is_ddim_at_first_order_and_exact_for_a_constant_prediction():
    """Without a previous prediction the 2M step is DDIM (eta 0); with the same prediction twice it still lands on
    the forward process; a previous prediction that differs moves the step by the 2M extrapolation."""
    schedule = DiffusionSchedule()
    x0 = torch.randn(3, 4, 5, dtype=torch.float64)
    noise = torch.randn_like(x0)
    x_t = schedule.add_noise(x0, 27, noise)
    assert torch.allclose(schedule.dpm_solver_2m_step(x_t, x0, 27, 21), schedule.ddim_step(x_t, x0, 27, 21))
    second = schedule.dpm_solver_2m_step(x_t, x0, 27, 21, x0_before=x0, t_before=32)
    assert torch.allclose(second, schedule.add_noise(x0, 21, noise), atol=1e-6)
    shifted = schedule.dpm_solver_2m_step(x_t, x0, 27, 21, x0_before=x0 + 1.0, t_before=32)
    lam = {t: 0.5 * np.log(a / (1 - a)) for t, a in ((t, cosine_alphas_cumprod()[t]) for t in (32, 27, 21))}
    ratio = (lam[27] - lam[32]) / (lam[21] - lam[27])
    abar = cosine_alphas_cumprod()[21]
    expected = -np.sqrt(abar) * (1 - np.exp(-(lam[21] - lam[27]))) * 0.5 / ratio
    assert torch.allclose(shifted - second, torch.full_like(x0, expected), atol=1e-9)
    assert torch.equal(schedule.dpm_solver_2m_step(x_t, x0, 0, None), x0)
