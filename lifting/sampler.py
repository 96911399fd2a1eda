"""The guided sampler (Algorithm 1 of the paper), with a robust step rule and per-frame root translation.

Per kept diffusion step t (noisiest first, after skipping S)::

    x0 = G(x_t, t)                       # no gradient through the network
    repeat k times:                      # guidance on x0
        x0' = x0 - step * grad E(x0)     # E: reprojection (+ structural) energy
        accept or cut the step           # "backtrack" (default) or "paper"
    x_{t_prev} = DDIM(x_t, x0, t, t_prev)

All windows and hypotheses go through the network as one batch.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch

from lifting.camera import CameraBatch
from lifting.energy import ROBUST_LOSSES, Observations, bone_constancy_energy, reprojection_energy, symmetry_energy
from lifting.prior import PriorBundle
from lifting.representation import features_to_joints, joints_to_features
from lifting.schedule import DiffusionSchedule, sampling_steps
from lifting.translation import RayConstraints, ray_constraints, solve_translation

STEP_RULES = ("backtrack", "paper")
DIRECTIONS = ("gauss-newton", "gradient")


@dataclass(frozen=True)
class SamplerConfig:
    """Every knob of the sampler; defaults follow the paper (T=10, S=2, k=10) except where noted.

    ``energy_scale`` is the initial guidance step (lambda); ``decay`` cuts it when a
    step fails; ``step_rule`` "backtrack" rejects steps that raise the energy (or are
    not finite) and multiplies the step by ``grow`` after each accepted one, "paper"
    keeps every step and only cuts the scale. ``translation_smoothness``
    couples per-frame root offsets (0: independent frames). ``bone_weight`` and
    ``symmetry_weight`` switch on the structural energies (metres squared).
    """

    samples: int = 50
    steps: int = 10
    skip: int = 2
    guidance_iters: int = 10
    energy_scale: float = 1.0
    decay: float = 0.1
    grow: float = 2.0
    step_rule: str = "backtrack"
    direction: str = "gauss-newton"
    damping: float = 0.1
    robust: str = "l2"
    robust_scale: float = 0.05
    translation_smoothness: float = 1.0
    bone_weight: float = 0.0
    symmetry_weight: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        checks = [
            (self.samples >= 1, f"samples must be at least 1, got {self.samples}"),
            (1 <= self.steps <= 50, f"steps must be in 1..50, got {self.steps}"),
            (0 <= self.skip < self.steps, f"skip must be in 0..{self.steps - 1}, got {self.skip}"),
            (self.guidance_iters >= 0, f"guidance iterations must be >= 0, got {self.guidance_iters}"),
            (self.energy_scale > 0, f"energy scale must be positive, got {self.energy_scale}"),
            (0 < self.decay < 1, f"decay must be in (0, 1), got {self.decay}"),
            (self.grow >= 1, f"grow must be >= 1, got {self.grow}"),
            (self.direction in DIRECTIONS, f"unknown direction {self.direction!r}; choose {', '.join(DIRECTIONS)}"),
            (self.damping > 0, f"damping must be positive, got {self.damping}"),
            (self.step_rule in STEP_RULES, f"unknown step rule {self.step_rule!r}; choose {', '.join(STEP_RULES)}"),
            (self.robust in ROBUST_LOSSES, f"unknown robust loss {self.robust!r}; choose {', '.join(ROBUST_LOSSES)}"),
            (self.robust_scale > 0, f"robust scale must be positive, got {self.robust_scale}"),
            (self.translation_smoothness >= 0, "translation smoothness must be >= 0"),
            (self.bone_weight >= 0 and self.symmetry_weight >= 0, "structural energy weights must be >= 0"),
        ]
        for ok, message in checks:
            if not ok:
                raise ValueError(message)


@dataclass(frozen=True)
class Anchor:
    """Known joints for some frames of each hypothesis (window continuation).

    ``joints`` (B, N, F, 17, 3) world metres; ``mask`` (B, F) is 1 where a frame is
    anchored, 0 elsewhere; ``weight`` per squared metre, in energy units.
    """

    joints: torch.Tensor
    mask: torch.Tensor
    weight: float = 100.0


@dataclass(frozen=True)
class SampleResult:
    """Hypotheses ``joints`` (B, N, F, 17, 3) in world metres and their per-frame reprojection ``energy`` (B, N, F)."""

    joints: np.ndarray
    energy: np.ndarray


class GuidedProblem:
    """The energy of a batch of windows: decoding, root placement and all energy terms."""

    def __init__(
        self,
        prior: PriorBundle,
        obs: Observations,
        rays: RayConstraints | None,
        config: SamplerConfig,
        root_trajectory: torch.Tensor | None = None,
        anchor: Anchor | None = None,
    ) -> None:
        if rays is None and root_trajectory is None:
            raise ValueError("either ray constraints (to solve the root) or a known root trajectory is needed")
        self.prior, self.obs, self.rays, self.config = prior, obs, rays, config
        self.root_trajectory = root_trajectory
        self.anchor = anchor
        self.batch = obs.keypoints.shape[1]

    def local_joints(self, x0: torch.Tensor) -> torch.Tensor:
        """Normalised windows ``(B*N, F, D)`` -> joints ``(B, N, F, 17, 3)`` in the prior's frame."""
        joints = features_to_joints(self.prior.normalizer.denormalize(x0))
        return joints.reshape(self.batch, -1, *joints.shape[1:])

    def place(self, local: torch.Tensor) -> torch.Tensor:
        """Put local joints into the world: the known root trajectory, or the solved per-frame translation."""
        if self.root_trajectory is not None:
            return local - local[..., :1, :] + self.root_trajectory[:, None, :, None, :]
        offset = solve_translation(local, self.rays, self.obs.cameras, self.config.translation_smoothness)
        return local + offset[..., None, :]

    def frame_energy(self, joints: torch.Tensor) -> torch.Tensor:
        """Total per-frame energy ``(B, N, F)`` of world joints."""
        c = self.config
        energy = reprojection_energy(joints, self.obs, c.robust, c.robust_scale)
        if c.bone_weight > 0:
            energy = energy + c.bone_weight * bone_constancy_energy(joints)
        if c.symmetry_weight > 0:
            energy = energy + c.symmetry_weight * symmetry_energy(joints)
        if self.anchor is not None:
            gap = ((joints - self.anchor.joints) ** 2).sum(dim=(-1, -2))
            energy = energy + self.anchor.weight * self.anchor.mask[:, None, :] * gap
        return energy

    def energy_and_direction(self, x0: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Energy per hypothesis ``(B*N,)`` and the descent direction in ``x0`` space ``(B*N, F, D)``.

        "gradient": minus the gradient with respect to ``x0`` (the paper). "gauss-newton":
        minus a damped Gauss-Newton step per joint in world space (3x3 reprojection
        curvature of each joint over all cameras), mapped back to ``x0``; it converges in a
        few iterations where the plain gradient needs hundreds, and leaves the depth of a
        single view to the prior (no curvature there, only damping).
        """
        with torch.enable_grad():
            if self.config.direction == "gradient":
                x = x0.detach().requires_grad_(True)
                energy = self.frame_energy(self.place(self.local_joints(x))).sum(-1)
                (grad,) = torch.autograd.grad(energy.sum(), x)
                return energy.detach().reshape(-1), -grad
            joints = self.place(self.local_joints(x0.detach())).requires_grad_(True)
            energy = self.frame_energy(joints).sum(-1)
            (grad,) = torch.autograd.grad(energy.sum(), joints)
        curvature = self.reprojection_curvature(joints.detach())
        if self.anchor is not None:
            anchored = 2 * self.anchor.weight * self.anchor.mask[:, None, :, None, None, None]
            curvature = curvature + anchored * torch.eye(3, dtype=x0.dtype, device=x0.device)
        damping = self.config.damping * curvature.diagonal(dim1=-2, dim2=-1).mean(dim=(-1, -2, -3, -4))
        eye = torch.eye(3, dtype=x0.dtype, device=x0.device)
        system = curvature + (damping.reshape(*damping.shape, 1, 1, 1, 1, 1) + 1e-9) * eye
        step_joints = -torch.linalg.solve(system, grad.unsqueeze(-1)).squeeze(-1)
        step_features = joints_to_features(step_joints).reshape(x0.shape)
        direction = step_features / torch.as_tensor(self.prior.normalizer.std, dtype=x0.dtype, device=x0.device)
        return energy.detach().reshape(-1), direction

    def reprojection_curvature(self, joints: torch.Tensor) -> torch.Tensor:
        """Gauss-Newton curvature ``(B, N, F, 17, 3, 3)`` of the reprojection energy per joint (pinhole, no distortion)."""
        cams = self.obs.cameras
        cam = cams.to_camera_frame(joints)  # (C, B, N, F, 17, 3)
        z = cam[..., 2:3].clamp(min=1e-3)
        C = len(cams)
        focal = torch.stack([cams.K[:, 0, 0], cams.K[:, 1, 1]], -1) * self.obs.pixel_scale[:, None]  # (C, 2)
        shape = (C, *([1] * (cam.dim() - 2)))
        ratio = cam[..., :2] / z  # (C, ..., 2)
        rows = cams.R[:, :2].reshape(*shape, 2, 3) - ratio[..., None] * cams.R[:, 2].reshape(*shape, 1, 3)
        jac = focal.reshape(*shape, 2, 1) / z[..., None] * rows  # (C, ..., 2, 3)
        weight = self.obs.confidence.unsqueeze(2)[..., None, None]
        return (weight * jac.transpose(-1, -2) @ jac).sum(0)

    def guide(self, x0: torch.Tensor, iterations: int) -> torch.Tensor:
        """k guidance steps on ``x0`` ``(B*N, F, D)`` with the configured step rule."""
        c = self.config
        step = torch.full((x0.shape[0], 1, 1), c.energy_scale, dtype=x0.dtype, device=x0.device)
        energy, direction = self.energy_and_direction(x0)
        for _ in range(iterations):
            candidate = x0 + step * direction
            new_energy, new_direction = self.energy_and_direction(candidate)
            finite = torch.isfinite(new_energy) & torch.isfinite(new_direction).all(dim=(1, 2))
            worse = ~finite | (new_energy > energy)
            accept = ~worse if c.step_rule == "backtrack" else torch.ones_like(worse)
            mask = accept[:, None, None]
            x0 = torch.where(mask, candidate, x0)
            energy = torch.where(accept, new_energy, energy)
            direction = torch.where(mask, new_direction, direction)
            grown = step * c.grow if c.step_rule == "backtrack" else step
            step = torch.where(worse[:, None, None], step * c.decay, grown)
        return x0


def sample(
    prior: PriorBundle,
    obs: Observations,
    rays: RayConstraints | None,
    config: SamplerConfig,
    frames: int,
    root_trajectory: torch.Tensor | None = None,
    anchor: Anchor | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> SampleResult:
    """Draw ``config.samples`` hypotheses for each of the B windows of ``frames`` frames.

    ``root_trajectory`` (B, F, 3), if known, fixes the pelvis path; otherwise the
    root is solved per frame from ``rays``. ``progress(done, total)`` is called after
    every diffusion step.
    """
    problem = GuidedProblem(prior, obs, rays, config, root_trajectory, anchor)
    model = prior.model
    dtype = obs.keypoints.dtype
    device = obs.keypoints.device
    schedule = DiffusionSchedule(prior.config.diffusion_steps)
    steps = sampling_steps(config.steps, config.skip, prior.config.diffusion_steps)
    generator = torch.Generator(device="cpu").manual_seed(config.seed)
    shape = (problem.batch * config.samples, frames, prior.config.features)
    noise = torch.randn(shape, generator=generator, dtype=torch.float32).to(device=device, dtype=dtype)
    x_t = schedule.add_noise(torch.zeros_like(noise), int(steps[0]), noise)
    x0 = x_t
    for i, t in enumerate(steps):
        with torch.inference_mode():
            x0 = model(x_t, torch.tensor(int(t), device=device))
        x0 = problem.guide(x0.clone(), config.guidance_iters)
        t_prev = int(steps[i + 1]) if i + 1 < len(steps) else None
        x_t = schedule.ddim_step(x_t, x0, int(t), t_prev)
        if progress is not None:
            progress(i + 1, len(steps))
    with torch.no_grad():
        joints = problem.place(problem.local_joints(x0))
        energy = reprojection_energy(joints, obs, config.robust, config.robust_scale)
    return SampleResult(joints=joints.cpu().numpy(), energy=energy.cpu().numpy())


def cameras_and_rays(
    cameras: list, keypoints: np.ndarray, confidence: np.ndarray, dtype: torch.dtype = torch.float32
) -> tuple[Observations, RayConstraints]:
    """Observations and ray constraints for cameras (list of lifting.camera.Camera) and pixels ``(C, B, F, 17, 2)``."""
    batch = CameraBatch.from_cameras(cameras, dtype=dtype)
    obs = Observations.from_arrays(batch, keypoints, confidence, dtype=dtype)
    K = np.stack([c.K for c in cameras])
    dist = np.stack([c.dist for c in cameras])
    return obs, ray_constraints(batch, keypoints, confidence, K, dist)
