"""The closed-form root translation recovers known offsets."""

import numpy as np
import torch

from lifting.camera_rigs import ring_cameras
from lifting.sampler import cameras_and_rays
from lifting.translation import solve_translation
from lifting.camera import project


def _setup(heldout_window, views):
    cams = ring_cameras(4)[:views]
    pixels = np.stack([project(heldout_window, c) for c in cams])[:, None]
    obs, rays = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]), dtype=torch.float64)
    return obs, rays


def test_per_frame_translation_recovers_a_known_path(heldout_window):
    frames = len(heldout_window)
    offsets = np.stack([np.linspace(-0.3, 0.4, frames), np.linspace(0.5, 0.2, frames), np.full(frames, 0.1)], -1)
    local = torch.as_tensor(heldout_window - offsets[:, None, :])[None, None]
    for views in (4, 1):
        obs, rays = _setup(heldout_window, views)
        solved = solve_translation(local, rays, obs.cameras, smoothness=0.0)[0, 0].numpy()
        assert np.abs(solved - offsets).max() < 1e-4, views  # 0.1 mm (tiny Tikhonov term)
        smooth = solve_translation(local, rays, obs.cameras, smoothness=1.0)[0, 0].numpy()
        assert np.abs(smooth - offsets).max() < 1e-4, views  # a constant-velocity path costs no smoothness


def test_large_smoothness_gives_a_straight_path(heldout_window):
    obs, rays = _setup(heldout_window, 4)
    rng = np.random.default_rng(0)
    jitter = rng.normal(0, 0.02, (len(heldout_window), 1, 3))
    local = torch.as_tensor(heldout_window + jitter - [0.2, 0.1, 0.0])[None, None]
    solved = solve_translation(local, rays, obs.cameras, smoothness=1e6)[0, 0].numpy()
    assert np.abs(np.diff(solved, 2, axis=0)).max() < 1e-4  # no acceleration
    free = solve_translation(local, rays, obs.cameras, smoothness=0.0)[0, 0].numpy()
    assert np.abs(np.diff(free, 2, axis=0)).max() > 0.01  # per-frame offsets follow the jitter
    assert np.allclose(solved.mean(0), free.mean(0), atol=5e-3)
