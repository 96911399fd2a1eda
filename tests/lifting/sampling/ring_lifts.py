"""Lifts of a known motion seen by ring cameras, for the sampler's tests: the sampler's result and the cameras,
and each hypothesis's reprojection error in pixels."""

import numpy as np

from platypose.lifting.camera import project
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.sampling.sampler import cameras_and_rays, sample
from platypose.lifting.settings import SamplerConfig


def ring_lift(prior, truth, views, noise_px=0.0, **config):
    """``truth`` seen by the first ``views`` ring cameras (Gaussian noise of ``noise_px``), sampled with ``config``:
    the sampler's result and the cameras."""
    cams = ring_cameras(4)[:views]
    pixels = np.stack([project(truth, c) for c in cams])[:, None]
    if noise_px:
        pixels = pixels + np.random.default_rng(7).normal(0, noise_px, pixels.shape)
    obs, rays = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]))
    result = sample(prior, obs, rays, SamplerConfig(**config), frames=len(truth))
    return result, cams


def rms_px(result, views, width=1000):
    """Per-hypothesis RMS of the 2D reprojection error vector in pixels, (N,).

    Gaussian noise of sigma px per coordinate has an RMS 2D error of sqrt(2) sigma.
    """
    per_keypoint = result.energy[0].sum(-1) / (len(result.energy[0][0]) * 17 * views)
    return np.sqrt(per_keypoint) * width / 2
