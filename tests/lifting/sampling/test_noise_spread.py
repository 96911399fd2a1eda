"""The noise spread (lifting/sampling/noise_spread.py): hypotheses spread by the residuals' noise where views are
redundant, none where they are exact or alone."""

import numpy as np
import torch
from ring_lifts import ring_lift, rms_px


def test_noise_spread_covers_the_truth_as_often_as_it_claims(tiny_prior, heldout_window):
    """4 views, 2 px noise: the fits collapse onto one point per joint that misses the truth by the triangulation
    error; spread by the residuals' noise, the truth falls inside a hypotheses' ball about their median about as
    often as the ball's share of hypotheses (over three draws: one draw of one window covers 0.56-0.67 of the
    joint-frames at the 50 % ball, 0.95-0.99 at the 90 % one), and the spread adds no frame-to-frame jitter."""
    coverage = []
    for seed in range(3):
        result, _ = ring_lift(tiny_prior, heldout_window, views=4, noise_px=2.0, samples=50, seed=seed)
        median = np.median(result.joints[0], axis=0)
        radius = np.linalg.norm(result.joints[0] - median, axis=-1)  # (N, F, 17)
        truth_distance = np.linalg.norm(heldout_window - median, axis=-1)  # (F, 17)
        coverage.append([np.mean(truth_distance < np.quantile(radius, share, axis=0)) for share in (0.5, 0.9)])
    for share, covered in zip((0.5, 0.9), np.mean(coverage, axis=0)):
        assert abs(covered - share) < 0.15, (share, covered)
    hyps, fitted = result.joints[0], result.fitted[0]
    fitted_radius = np.linalg.norm(fitted - np.median(fitted, axis=0), axis=-1)
    assert np.mean(truth_distance < np.quantile(fitted_radius, 0.9, axis=0)) < 0.3  # collapsed: overconfident
    offsets = hyps - fitted
    change = np.linalg.norm(np.diff(offsets, axis=1), axis=-1)
    assert change.mean() < 0.1 * np.linalg.norm(offsets, axis=-1).mean(), (
        change.mean()
    )  # one draw per window: no jitter
    rms = rms_px(result, 4)
    assert np.all((rms > 0.8 * np.sqrt(2) * 2.0) & (rms < 1.5 * np.sqrt(2) * 2.0)), (
        rms
    )  # as far from the 2D as the truth


def test_noise_spread_ignores_frames_without_a_fit():
    """A track's padding frames (no keypoints, joints NaN) leave the other frames' spread finite."""
    from platypose.lifting.sampling.noise_spread import unit_weight_variance

    energy = torch.tensor([[[1.0, 2.0, float("nan")], [3.0, 1.0, float("nan")]]])  # (B=1, N=2, F=3)
    confidence = torch.ones(2, 1, 3, 17)
    confidence[:, :, 2] = 0  # frame 2 unobserved
    variance = unit_weight_variance(energy, confidence)
    assert torch.allclose(variance, torch.tensor([3.0 / (2 * 17 * (2 * 2 - 3))]))  # median fit 3 over 34 redundant


def test_noise_free_views_get_no_spread(tiny_prior, heldout_window):
    result, _ = ring_lift(tiny_prior, heldout_window, views=4, samples=20)
    assert np.abs(result.joints - result.fitted).max() < 0.002
    one_view, _ = ring_lift(tiny_prior, heldout_window, views=1, noise_px=2.0, samples=5)
    assert np.array_equal(one_view.joints, one_view.fitted)  # one camera: nothing redundant to measure noise by
