"""The guided sampler (Algorithm 1 of the paper), with a robust step rule and per-frame root translation.

Per kept diffusion step t (noisiest first, after skipping S)::

    x0 = G(x_t, t)                       # no gradient through the network
    repeat k times:                      # guidance on x0
        x0' = x0 - step * grad E(x0)     # E: reprojection (+ structural) energy
        accept or cut the step           # "backtrack" (default) or "paper"
    x_{t_prev} = DDIM(x_t, x0, t, t_prev)

All windows and hypotheses go through the network as one batch. Each window's noise comes from its own key
(:func:`window_key`: the seed, whose window, where it starts), so a window is sampled alike whichever windows share
its batch: a person's lift does not depend on who else is in the take, nor on how a long take is cut into pieces.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from platypose.lifting.camera import CameraBatch
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.prior.schedule import DiffusionSchedule, sampling_steps
from platypose.lifting.sampling.energy import Observations, reprojection_energy
from platypose.lifting.sampling.guidance import GuidedProblem
from platypose.lifting.sampling.placement import Anchor
from platypose.lifting.sampling.translation import RayConstraints, ray_constraints
from platypose.lifting.sampling.views import views_for
from platypose.lifting.settings import SamplerConfig


@dataclass(frozen=True)
class SampleResult:
    """Hypotheses ``joints`` (B, N, F, 17, 3) in world metres and their per-frame reprojection ``energy`` (B, N, F).

    ``fitted`` are the joints as guidance and the noise fit left them, before the noise spread
    (the same array without it); the next window of a long track continues these.
    """

    joints: np.ndarray
    energy: np.ndarray
    fitted: np.ndarray


def window_key(seed: int, identity: int, start: int) -> int:
    """The noise key of a window: the sampler's ``seed``, whose window it is (``identity``: a person's track id) and
    where it starts (``start``: its first frame on the prior's clock counted from time 0), mixed into one 64-bit
    integer (numpy's SeedSequence, so nearby keys give unrelated noise)."""
    entropy = [int(seed) % 2**64, int(identity) % 2**64, int(start) % 2**64]
    return int(np.random.SeedSequence(entropy).generate_state(1, dtype=np.uint64)[0])


def window_normal(generators: Sequence[torch.Generator], shape: tuple[int, ...]) -> torch.Tensor:
    """Standard normal draws ``(len(generators) * shape[0], *shape[1:])``: each window's ``shape`` from its own
    generator, in window order."""
    return torch.cat([torch.randn(shape, generator=g, dtype=torch.float32) for g in generators])


def antithetic_normal(count: int, generator: torch.Generator) -> torch.Tensor:
    """``count`` standard normal draws ``(count, 17, 3)`` in pairs z, -z, so that their median is zero to the last bit."""
    half = torch.randn(((count + 1) // 2, 17, 3), generator=generator)
    return torch.cat([half, -half])[:count]


def network_steps(prior: PriorBundle, config: SamplerConfig) -> np.ndarray:
    """The diffusion steps the sampler calls the network at, noisiest first.

    A distilled prior is called at the steps it was trained for (``--steps``/``--skip`` do not
    apply), re-noised by DDIM; any other prior at ``config``'s respaced steps.
    """
    if prior.fixed_steps is None:
        return sampling_steps(config.steps, config.skip, prior.config.diffusion_steps)
    if config.solver != "ddim":
        raise ValueError(f"a distilled prior is sampled with the ddim solver, not {config.solver}")
    return prior.fixed_steps


def sample(
    prior: PriorBundle,
    obs: Observations,
    rays: RayConstraints | None,
    config: SamplerConfig,
    frames: int,
    *,
    root_trajectory: torch.Tensor | None = None,
    anchor: Anchor | None = None,
    progress: Callable[[int, int], None] | None = None,
    window_keys: Sequence[int] | None = None,
) -> SampleResult:
    """Draw ``config.samples`` hypotheses for each of the B windows of ``frames`` frames.

    ``root_trajectory`` (B, F, 3), if known, fixes the pelvis path; otherwise the
    root is solved per frame from ``rays``. ``progress(done, total)`` is called after
    every diffusion step. ``window_keys`` (B,): each window's noise key (:func:`window_key`; None: the window's
    place in the batch stands for its identity and start). The per-hypothesis draws (size, noise spread,
    support) come from ``config.seed`` alone: hypothesis n is the same kind of body in every window.
    """
    model = prior.model
    dtype = obs.keypoints.dtype
    device = obs.keypoints.device
    schedule = DiffusionSchedule(prior.config.diffusion_steps)
    steps = network_steps(prior, config)
    generator = torch.Generator(device="cpu").manual_seed(config.seed)
    windows = obs.keypoints.shape[1]
    keys = [window_key(config.seed, b, 0) for b in range(windows)] if window_keys is None else list(window_keys)
    if len(keys) != windows:
        raise ValueError(f"{len(keys)} window keys for {windows} windows")
    streams = [torch.Generator(device="cpu").manual_seed(key) for key in keys]  # each window's own noise
    shape = (config.samples, frames, prior.config.features)  # one window's
    temperature = config.temperature * (prior.temperature_for(frames) if obs.keypoints.shape[0] == 1 else 1.0)
    noise = (temperature * window_normal(streams, shape)).to(device=device, dtype=dtype)
    sizes = (
        torch.exp(config.size_spread * torch.randn(config.samples, generator=generator))
        if config.size_spread > 0
        else None
    )
    draws = antithetic_normal(config.samples, generator)  # the noise spread's, one (17, 3) per hypothesis
    support = choices = None  # each hypothesis's stance height and floor-reading draw, after the other draws
    if config.floor is not None:
        support = config.support_spread * torch.randn(config.samples, generator=generator)
        choices = torch.rand(config.samples, generator=generator)
    raw = obs  # the reported energy is against the keypoints as given
    views = views_for(obs.cameras)
    obs, rays = views.prepare(obs, rays, config)
    problem = GuidedProblem(
        prior,
        obs,
        rays,
        config,
        root_trajectory=root_trajectory,
        anchor=anchor,
        size_factors=sizes,
        views=views,
        stance_heights=support,
        floor_choices=choices,
    )
    x_t = schedule.add_noise(torch.zeros_like(noise), int(steps[0]), noise)
    x0 = x_t
    before: tuple[torch.Tensor, int] | None = None  # the previous guided prediction and its step (dpm2m)
    for i, t in enumerate(steps):
        with torch.inference_mode():
            x0 = model(x_t, torch.tensor(int(t), device=device))
        t_prev = int(steps[i + 1]) if i + 1 < len(steps) else None
        # the last step carries guidance's moves over the unseen joints (:mod:`lifting.sampling.unseen`)
        x0, offset = problem.guide(problem.inpaint(x0.clone()), config.guidance_iters, bridge_unseen=t_prev is None)
        if t_prev is not None:  # the last prediction keeps its own overlap, pulled by the anchor energy, for blending
            x0 = problem.inpaint(x0)
        fresh = window_normal(streams, shape).to(device=device, dtype=dtype) if config.eta > 0 else None
        if config.solver == "dpm2m":
            x_t = schedule.dpm_solver_2m_step(x_t, x0, int(t), t_prev, *(before or (None, None)))
            before = (x0, int(t))
        else:
            x_t = schedule.ddim_step(x_t, x0, int(t), t_prev, config.eta, fresh)
        if progress is not None:
            progress(i + 1, len(steps))
    with torch.no_grad():
        fitted, joints = views.fit_and_spread(problem.world_joints(x0, offset), obs, draws, config, prior.fps)
        energy = reprojection_energy(joints, raw, config.robust, config.robust_scale)
    return SampleResult(joints.cpu().numpy(), energy.cpu().numpy(), fitted.cpu().numpy())


def cameras_and_rays(
    cameras: list,
    keypoints: np.ndarray,
    confidence: np.ndarray,
    dtype: torch.dtype = torch.float32,
    device: str | torch.device = "cpu",
) -> tuple[Observations, RayConstraints]:
    """Observations and ray constraints for cameras (list of lifting.camera.Camera) and pixels ``(C, B, F, 17, 2)``.

    The tensors live on ``device``; the sampler runs wherever the observations are.
    """
    batch = CameraBatch.from_cameras(cameras, dtype=dtype, device=device)
    obs = Observations.from_arrays(batch, keypoints, confidence, dtype=dtype)
    return obs, ray_constraints(obs)
