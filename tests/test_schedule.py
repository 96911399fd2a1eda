"""Cosine schedule, ddimN respacing with skip, and DDIM re-noising."""

import numpy as np
import torch

from platypose.lifting.schedule import DiffusionSchedule, cosine_alphas_cumprod, respaced_steps, sampling_steps


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
