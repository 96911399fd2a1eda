"""The closed-form root translation recovers known offsets."""

import numpy as np
import torch

from platypose.lifting.camera import project
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.sampling.sampler import cameras_and_rays
from platypose.lifting.sampling.translation import solve_translation


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


def test_windows_seen_once_or_never_are_solved_in_float32(real_clips):
    """One camera, 64 float32 frames of a person 9 m away seen in one frame or in none (a lost track): the
    frames without evidence leave only a tiny ridge and the acceleration penalty, whose straight lines are
    free; float32 Cholesky failed on this at smoothness 10 and 100."""
    from platypose.lifting.timebase import resample

    climb = next(m for m in real_clips if "climb" in m.name)
    truth = resample(climb.joints, climb.fps, 30.0)[:64]
    cam = ring_cameras(4)[0]
    truth = truth - truth[:, 0].mean(0) + cam.center + 9.0 * cam.R[2]
    pixels = project(truth, cam)[None, None]  # (C=1, B=1, F, 17, 2)
    local = torch.as_tensor(truth - truth[:, :1], dtype=torch.float32)[None, None]
    for seen in ([0], []):
        confidence = np.zeros(pixels.shape[:-1])
        confidence[:, :, seen] = 1.0
        obs, rays = cameras_and_rays([cam], pixels, confidence, dtype=torch.float32)
        for smoothness in (1.0, 10.0, 100.0):
            solved = solve_translation(local, rays, obs.cameras, smoothness)[0, 0].numpy()
            assert np.isfinite(solved).all(), (seen, smoothness)
            if seen:
                assert np.abs(solved[0] - truth[0, 0]).max() < 0.05, smoothness  # the seen frame stays on its rays
