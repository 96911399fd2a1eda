"""One camera or several: everything the sampler does differently for them, chosen once (:func:`views_for`).

One camera fixes each joint's ray, not its depth: the depth is the prior's. There the roots'
depths are limited to near their window's median hypothesis, guidance runs in the camera's
axes (cheaper, the same energies), every joint's depth path is smoothed along its ray after
guidance, and the keypoints' own paths are smoothed to their noise before it. Several cameras
measure depth: the fit follows the keypoints as far as their noise allows, and the hypotheses
spread by the uncertainty that noise leaves.
"""

from __future__ import annotations

import torch

from platypose.lifting.camera import CameraBatch
from platypose.lifting.sampling.depth_smoothing import smooth_depth
from platypose.lifting.sampling.energy import Observations, reprojection_terms
from platypose.lifting.sampling.linalg import rotate_translate
from platypose.lifting.sampling.noise_spread import noise_spread, unit_weight_variance
from platypose.lifting.sampling.placement import limit_depth
from platypose.lifting.sampling.temporal_fit import (
    acceleration_weight,
    fit_to_noise,
    keypoint_noise,
    posterior_shrink,
    smooth_keypoints,
)
from platypose.lifting.sampling.translation import RayConstraints, ray_constraints
from platypose.lifting.settings import SamplerConfig


class OneView:
    """The sampler's steps for one camera (see the module)."""

    def __init__(self, cameras: CameraBatch) -> None:
        self.rotation, self.translation = cameras.R[0], cameras.t[0]

    def prepare(
        self, obs: Observations, rays: RayConstraints | None, config: SamplerConfig
    ) -> tuple[Observations, RayConstraints | None]:
        """The observations guidance fits: with ``noise_fit`` the keypoints' most likely paths (and their rays)."""
        if not config.noise_fit:
            return obs, rays
        obs = smooth_keypoints(obs, keypoint_noise(obs))
        return obs, ray_constraints(obs) if rays is not None else None

    def limit_offset(self, roots: torch.Tensor, offset: torch.Tensor) -> torch.Tensor:
        """Offsets ``(B, N, F, 3)`` of ``roots`` ``(B, N, F, 3)`` with the placed roots' depths limited
        (:func:`lifting.sampling.placement.limit_depth`): a few poorly fitting early predictions fell towards the camera."""
        return limit_depth(roots + offset, self.rotation, self.translation) - roots

    def guidance_frame(self, config: SamplerConfig) -> tuple[torch.Tensor, torch.Tensor] | None:
        """The camera's ``(R, t)`` for Gauss-Newton steps: its terms and each joint's 3x3 system are far cheaper
        in its axes, where the Jacobian rows are (1, 0, -u) and (0, 1, -v); every energy is the same there."""
        return (self.rotation, self.translation) if config.direction == "gauss-newton" else None

    def depth_smoothed_move(
        self,
        start: torch.Tensor,
        moved: torch.Tensor,
        in_camera: bool,
        anchored: torch.Tensor | None,
        config: SamplerConfig,
    ) -> torch.Tensor:
        """The guidance move ``(3, B, N, F, 17)`` from ``start`` after which every joint's depth path is smoothed
        (:mod:`lifting.sampling.depth_smoothing`); ``start`` and ``moved`` are in the camera's frame or (not ``in_camera``)
        the world's; ``anchored`` ``(B, F)`` marks frames held to the window before. Joints that are not finite
        (frames outside a given root path) keep ``moved``."""
        if config.depth_smoothness <= 0:
            return moved
        rotation, translation = self.rotation, self.translation
        joints = start + moved if in_camera else rotate_translate(start + moved, rotation, translation)
        smoothed = smooth_depth(joints, config.depth_smoothness, anchored)
        if not in_camera:
            smoothed = rotate_translate(smoothed, rotation.T, -rotation.T @ translation)
        smoothed_move = smoothed - start
        return torch.where(torch.isfinite(smoothed_move), smoothed_move, moved)  # frames without a root keep theirs

    def fit_and_spread(
        self, fitted: torch.Tensor, obs: Observations, draws: torch.Tensor, config: SamplerConfig, fps: float
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """(fitted, hypotheses): one camera has nothing redundant to measure noise by, both are the fit."""
        return fitted, fitted


class SeveralViews:
    """The sampler's steps for two or more cameras (see the module)."""

    def prepare(
        self, obs: Observations, rays: RayConstraints | None, config: SamplerConfig
    ) -> tuple[Observations, RayConstraints | None]:
        """The observations guidance fits: the keypoints as given."""
        return obs, rays

    def limit_offset(self, roots: torch.Tensor, offset: torch.Tensor) -> torch.Tensor:
        """Offsets as the rays placed them: several views measure depth."""
        return offset

    def guidance_frame(self, config: SamplerConfig) -> None:
        """Guidance runs in world axes."""
        return None

    def depth_smoothed_move(
        self,
        start: torch.Tensor,
        moved: torch.Tensor,
        in_camera: bool,
        anchored: torch.Tensor | None,
        config: SamplerConfig,
    ) -> torch.Tensor:
        """The guidance move as it is: the views hold every joint's depth."""
        return moved

    def fit_and_spread(
        self, fitted: torch.Tensor, obs: Observations, draws: torch.Tensor, config: SamplerConfig, fps: float
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """(fitted, hypotheses): the guided fit ``(B, N, F, 17, 3)`` moved by the noise fit, and the hypotheses
        spread from it by ``draws`` (:mod:`lifting.sampling.noise_spread`); with both steps off, both are the fit."""
        if not (config.noise_fit or config.noise_spread):
            return fitted, fitted
        energy, _, curvature = reprojection_terms(fitted, obs)
        variance = unit_weight_variance(energy, obs.confidence)  # of the exact fit: the views' disagreement and jitter
        smoothed = None
        if config.noise_fit:
            noise = keypoint_noise(obs)
            fitted = fit_to_noise(fitted, obs, noise, fps)
            _, _, curvature = reprojection_terms(fitted, obs)
            smoothed = noise**2, posterior_shrink(curvature, acceleration_weight(noise, fps))
        if not config.noise_spread:
            return fitted, fitted
        return fitted, fitted + noise_spread(curvature, obs.confidence, draws, variance, smoothed)


def views_for(cameras: CameraBatch) -> OneView | SeveralViews:
    """The sampler's one-camera or several-camera steps for ``cameras``: the one place that choice is made."""
    return OneView(cameras) if len(cameras) == 1 else SeveralViews()
