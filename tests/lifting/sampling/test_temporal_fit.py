"""The keypoints' own noise and the fit to it (lifting/sampling/temporal_fit.py): noise measured from a track's
jitter, keypoint paths smoothed to it, lifts that follow the keypoints only as far as their noise."""

import numpy as np
import torch
from ring_lifts import ring_lift

from platypose.lifting.camera import project
from platypose.lifting.offline import metrics
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.sampling.sampler import cameras_and_rays


def test_straight_exact_paths_are_left_alone():
    """Keypoints of a straight 3D path without noise (second differences nearly zero) stay as they are."""
    from platypose.lifting.sampling.temporal_fit import keypoint_noise, smooth_keypoints

    cam = ring_cameras(4)[0]
    walk = np.zeros((16, 17, 3)) + np.linspace(0, 1, 17)[None, :, None] * [0, 0, 1.0] + [0, 0, 0.5]
    walk = walk + np.arange(16)[:, None, None] * [0.03, 0.0, 0.0]
    pixels = project(walk, cam)[None, None]
    obs, _ = cameras_and_rays([cam], pixels, np.ones(pixels.shape[:-1]), dtype=torch.float64)
    smoothed = smooth_keypoints(obs, keypoint_noise(obs)).normalized
    assert torch.isfinite(smoothed).all() and (smoothed - obs.normalized).abs().max() * cam.K[0, 0] < 0.01  # pixels


def test_keypoint_noise_is_measured_from_the_tracks_own_jitter(heldout_window):
    from platypose.lifting.sampling.temporal_fit import keypoint_noise

    cams = ring_cameras(4)
    pixels = np.stack([project(heldout_window, c) for c in cams])[:, None]  # (C, B=1, F, 17, 2)
    noisy = pixels + np.random.default_rng(3).normal(0, 3.0, pixels.shape)
    for observed, expected_px in ((pixels, None), (noisy, 3.0)):
        obs, _ = cameras_and_rays(cams, observed, np.ones(observed.shape[:-1]))
        measured_px = float(keypoint_noise(obs)[0]) / float(obs.pixel_scale[0])
        if expected_px is None:
            assert measured_px < 0.5, measured_px  # real walking alone: its accelerations are a fraction of a pixel
        else:
            assert abs(measured_px - expected_px) < 0.15 * expected_px, measured_px


def test_noise_fit_follows_the_keypoints_only_as_far_as_their_noise(tiny_prior, heldout_window):
    """4 views, 3 px noise: fitting every frame exactly puts the noise into the motion; the noise fit is nearer
    the truth and moves as smoothly as it; exact keypoints are fitted as before."""
    exact, _ = ring_lift(
        tiny_prior, heldout_window, views=4, noise_px=3.0, samples=10, noise_fit=False, noise_spread=False
    )
    fitted, _ = ring_lift(tiny_prior, heldout_window, views=4, noise_px=3.0, samples=10, noise_spread=False)
    truth_speed = np.linalg.norm(np.diff(heldout_window, axis=0), axis=-1).mean()
    error = [np.linalg.norm(r.joints[0] - heldout_window, axis=-1).mean() for r in (exact, fitted)]
    velocity_error = [metrics.mpjve(r.joints[0], heldout_window) for r in (exact, fitted)]
    assert error[1] < 0.8 * error[0], error
    assert velocity_error[1] < 0.5 * velocity_error[0] < truth_speed, (velocity_error, truth_speed)
    clean, _ = ring_lift(tiny_prior, heldout_window, views=4, samples=10, noise_spread=False)
    assert np.linalg.norm(clean.joints[0] - heldout_window, axis=-1).mean() < 0.002


def test_padding_frames_are_held_for_the_noise_fit_and_stay_missing(tiny_prior, heldout_window):
    """A track's last window is padded with frames without joints (NaN): the noise fit holds the nearest frame
    there (a banded solve cannot take NaN), fits the rest, and gives the padding back as NaN."""
    from platypose.lifting.sampling.temporal_fit import fit_to_noise, hold_nearest, keypoint_noise

    values = torch.arange(5.0).reshape(1, 1, 5, 1, 1).expand(1, 1, 5, 17, 3).clone()
    valid = torch.tensor([False, True, True, True, False]).reshape(1, 1, 5, 1).expand(1, 1, 5, 17)
    held = hold_nearest(values, valid)[0, 0, :, 0, 0]
    assert held.tolist() == [1.0, 1.0, 2.0, 3.0, 3.0]
    cams = ring_cameras(4)
    pixels = np.stack([project(heldout_window, c) for c in cams])[:, None]
    pixels = pixels + np.random.default_rng(5).normal(0, 2.0, pixels.shape)
    confidence = np.ones(pixels.shape[:-1])
    confidence[:, :, -3:] = 0.0
    obs, _ = cameras_and_rays(cams, pixels, confidence)
    joints = torch.as_tensor(np.repeat(heldout_window[None, None], 3, axis=1), dtype=torch.float32).clone()
    joints[:, :, -3:] = float("nan")
    fitted = fit_to_noise(joints, obs, keypoint_noise(obs), 30.0)
    assert torch.isnan(fitted[:, :, -3:]).all() and torch.isfinite(fitted[:, :, :-3]).all()


def test_one_view_keypoint_paths_are_smoothed_to_their_noise(tiny_prior, heldout_window):
    """One camera, 3 px noise: the smoothed keypoint paths are nearer the true projections than the noisy ones,
    exact keypoints stay as they are, and the lift moves less jerkily than one fitting every frame exactly."""
    from platypose.lifting.sampling.temporal_fit import keypoint_noise, smooth_keypoints

    cam = ring_cameras(4)[0]
    clean = project(heldout_window, cam)[None, None]  # (C, B, F, 17, 2)
    noisy = clean + np.random.default_rng(11).normal(0, 3.0, clean.shape)
    obs_noisy, _ = cameras_and_rays([cam], noisy, np.ones(noisy.shape[:-1]))
    obs_clean, _ = cameras_and_rays([cam], clean, np.ones(clean.shape[:-1]))
    smoothed = smooth_keypoints(obs_noisy, keypoint_noise(obs_noisy)).normalized
    error_before = (obs_noisy.normalized - obs_clean.normalized).norm(dim=-1).mean()
    error_after = (smoothed - obs_clean.normalized).norm(dim=-1).mean()
    assert error_after < 0.7 * error_before, (error_after, error_before)
    kept = smooth_keypoints(obs_clean, keypoint_noise(obs_clean)).normalized
    assert (kept - obs_clean.normalized).norm(dim=-1).max() * cam.K[0, 0] < 1.0  # pixels: the walk's own accelerations
    exact, _ = ring_lift(tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10, noise_fit=False)
    fitted, _ = ring_lift(tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10)
    jerk = [np.abs(np.diff(r.joints[0], 2, axis=1)).mean() for r in (exact, fitted)]
    assert jerk[1] < 0.7 * jerk[0], jerk
