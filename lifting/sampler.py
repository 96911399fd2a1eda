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

from platypose.lifting.camera import CameraBatch
from platypose.lifting.depth_smoothing import smooth_depth
from platypose.lifting.energy import (
    ROBUST_LOSSES,
    Observations,
    add_to_diagonal_,
    bone_constancy_energy,
    bone_lengths_torch,
    reprojection_energy,
    reprojection_terms,
    solve_symmetric3,
    symmetry_energy,
)
from platypose.lifting.noise_spread import noise_spread, unit_weight_variance
from platypose.lifting.prior import PriorBundle
from platypose.lifting.representation import features_to_joints, joints_to_features
from platypose.lifting.schedule import DiffusionSchedule, sampling_steps
from platypose.lifting.skeleton import SIZE_BONES, TYPICAL_BONE_LENGTHS
from platypose.lifting.temporal_fit import (
    acceleration_weight,
    fit_to_noise,
    keypoint_noise,
    posterior_shrink,
    smooth_keypoints,
)
from platypose.lifting.translation import RayConstraints, ray_constraints, solve_translation

STEP_RULES = ("backtrack", "paper")
DEPTH_RANGE = 1.5  # one view: a root over this many times nearer or farther than the median hypothesis is moved back
SIZE_LIMITS = (0.5, 2.0)  # the size prior never scales a prediction by more than this
DIRECTIONS = ("gauss-newton", "gradient")


@dataclass(frozen=True)
class SamplerConfig:
    """Every knob of the sampler; defaults follow the paper (T=10, S=2, k=10) except where noted.

    ``energy_scale`` is the initial guidance step (lambda); ``decay`` cuts it when a
    step fails; ``step_rule`` "backtrack" rejects steps that raise the energy (or are
    not finite) and multiplies the step by ``grow`` after each accepted one, "paper"
    keeps every step and only cuts the scale. ``translation_smoothness``
    couples per-frame root offsets (0: independent frames; 100 keeps one view's root depth
    from jittering frame to frame). ``size_prior`` places each
    new network prediction where a person of typical adult size would stand (one
    view cannot tell a small near person from a tall far one; guidance then fits the
    pose at that place); ``size_spread`` gives each hypothesis its own size, typical
    times ``exp(size_spread * n)`` with n standard normal (adults' heights vary by
    about 4 %, their proportions more; 0: every hypothesis typical). With two or more
    cameras, ``noise_fit`` makes the last fit follow the keypoints only as far as their
    noise (measured from their own jitter) allows, against a prior on joint accelerations
    (:mod:`lifting.temporal_fit`); with one camera it smooths the keypoints' paths the same
    way before guidance fits them. With two or more cameras ``noise_spread`` moves each hypothesis by a draw of
    the joints' remaining uncertainty under that noise (:mod:`lifting.noise_spread`). ``bone_weight`` and
    ``symmetry_weight`` switch on the structural energies (metres squared). With one camera,
    ``depth_smoothness`` smooths every joint's depth path along its ray after each diffusion
    step's guidance (:mod:`lifting.depth_smoothing`; 0: off).
    ``guidance_iters`` (k) is a maximum: guidance stops early once every hypothesis
    took a step gaining less than ``guidance_tol`` of its energy at the start of this
    diffusion step's guidance, or its step has shrunk to nothing (0: always k).
    """

    samples: int = 50
    steps: int = 10
    skip: int = 2
    eta: float = 0.0
    guidance_iters: int = 10
    guidance_tol: float = 1e-3
    energy_scale: float = 1.0
    decay: float = 0.1
    grow: float = 2.0
    step_rule: str = "backtrack"
    direction: str = "gauss-newton"
    damping: float = 0.1
    robust: str = "l2"
    robust_scale: float = 0.05
    translation_smoothness: float = 100.0
    size_prior: bool = True
    size_spread: float = 0.1
    noise_fit: bool = True
    noise_spread: bool = True
    bone_weight: float = 0.0
    symmetry_weight: float = 0.0
    depth_smoothness: float = 10.0
    seed: int = 0

    def __post_init__(self) -> None:
        checks = [
            (self.samples >= 1, f"samples must be at least 1, got {self.samples}"),
            (1 <= self.steps <= 50, f"steps must be in 1..50, got {self.steps}"),
            (0 <= self.skip < self.steps, f"skip must be in 0..{self.steps - 1}, got {self.skip}"),
            (0 <= self.eta <= 1, f"eta must be in [0, 1], got {self.eta}"),
            (self.guidance_iters >= 0, f"guidance iterations must be >= 0, got {self.guidance_iters}"),
            (self.guidance_tol >= 0, f"guidance tolerance must be >= 0, got {self.guidance_tol}"),
            (self.energy_scale > 0, f"energy scale must be positive, got {self.energy_scale}"),
            (0 < self.decay < 1, f"decay must be in (0, 1), got {self.decay}"),
            (self.grow >= 1, f"grow must be >= 1, got {self.grow}"),
            (self.direction in DIRECTIONS, f"unknown direction {self.direction!r}; choose {', '.join(DIRECTIONS)}"),
            (self.damping > 0, f"damping must be positive, got {self.damping}"),
            (self.step_rule in STEP_RULES, f"unknown step rule {self.step_rule!r}; choose {', '.join(STEP_RULES)}"),
            (self.robust in ROBUST_LOSSES, f"unknown robust loss {self.robust!r}; choose {', '.join(ROBUST_LOSSES)}"),
            (self.robust_scale > 0, f"robust scale must be positive, got {self.robust_scale}"),
            (self.translation_smoothness >= 0, "translation smoothness must be >= 0"),
            (0 <= self.size_spread <= 0.5, f"size spread must be in [0, 0.5], got {self.size_spread}"),
            (self.bone_weight >= 0 and self.symmetry_weight >= 0, "structural energy weights must be >= 0"),
            (self.depth_smoothness >= 0, f"depth smoothness must be >= 0, got {self.depth_smoothness}"),
        ]
        for ok, message in checks:
            if not ok:
                raise ValueError(message)


@dataclass(frozen=True)
class Anchor:
    """Known joints for some frames of each hypothesis (window continuation).

    ``joints`` (B, N, F, 17, 3) world metres; ``mask`` (B, F) is 1 where a frame is
    anchored, 0 elsewhere, and frame 0 must be anchored. Anchored frames are in-painted
    (their features replace the prediction's at every step, so the network continues
    them) and held by an energy of ``weight`` per squared metre.
    """

    joints: torch.Tensor
    mask: torch.Tensor
    weight: float = 100.0


@dataclass(frozen=True)
class SampleResult:
    """Hypotheses ``joints`` (B, N, F, 17, 3) in world metres and their per-frame reprojection ``energy`` (B, N, F).

    ``fitted`` are the joints as guidance and the noise fit left them, before the noise spread
    (the same array without it); the next window of a long track continues these.
    """

    joints: np.ndarray
    energy: np.ndarray
    fitted: np.ndarray


def continuation_ramp(mask: torch.Tensor) -> torch.Tensor:
    """Weights ``(B, F)``: 1 over each row's anchored first frames, then falling linearly to 0 at the last frame.

    Blending the continued placement (weight 1) into the rays' own placement with
    these weights joins a window to the one before without letting the placement
    drift from window to window (with one camera, windows that only continued their
    predecessor drifted towards the camera: 5.5 m to 0.3 m in 15 s).
    """
    F = mask.shape[-1]
    frames = torch.arange(F, dtype=mask.dtype, device=mask.device)
    last_anchored = (mask.sum(-1, keepdim=True) - 1).clamp(min=0)  # (B, 1)
    return ((F - 1 - frames) / (F - 1 - last_anchored).clamp(min=1)).clamp(0, 1)


def typical_size(joints: torch.Tensor, factors: torch.Tensor | None = None) -> torch.Tensor:
    """Scale the poses ``(B, N, F, 17, 3)`` about their pelvis to adult size.

    Size is the sum of limb and trunk lengths (median over frames). Without ``factors``
    one scale per window (median over its hypotheses) brings the window to typical size
    and keeps the hypotheses' relative sizes; with ``factors`` ``(N,)`` hypothesis n is
    brought to typical x ``factors[n]``. Scales are clamped to ``SIZE_LIMITS``.
    """
    lengths = bone_lengths_torch(joints)[..., list(SIZE_BONES)].sum(-1)  # (B, N, F)
    typical = sum(TYPICAL_BONE_LENGTHS[b] for b in SIZE_BONES)
    if factors is None:
        size = lengths.flatten(1).median(dim=-1).values[:, None]  # (B, 1)
        target = torch.full_like(size, typical)
    else:
        size = lengths.median(dim=-1).values  # (B, N)
        target = typical * factors.to(lengths)[None]
    scale = (target / size.clamp(min=1e-3)).clamp(*SIZE_LIMITS)
    root = joints[..., :1, :]
    return root + scale[..., None, None, None] * (joints - root)


def limit_depth(roots: torch.Tensor, rotation: torch.Tensor, translation: torch.Tensor) -> torch.Tensor:
    """Move roots ``(B, N, F, 3)`` (world) along their camera rays to within ``DEPTH_RANGE`` times the
    median depth of the N hypotheses of their window and frame (camera ``rotation`` (3, 3), ``translation`` (3,)).

    A root too near is put at ``median / DEPTH_RANGE`` on its own ray; one (nearly) beside or behind
    the camera (depth under ``median / DEPTH_RANGE**2``) has no usable ray and takes the median ray
    of the hypotheses instead, so a root is never thrown far sideways.
    """
    center = -translation @ rotation  # camera centre in the world
    ray = roots - center
    depth = ray @ rotation[2]  # (B, N, F)
    median = depth.median(dim=1, keepdim=True).values.clamp(min=1e-3)  # (B, 1, F)
    limited = torch.minimum(torch.maximum(depth, median / DEPTH_RANGE), median * DEPTH_RANGE)
    median_ray = ray.median(dim=1, keepdim=True).values  # (B, 1, F, 3), componentwise
    median_ray = median_ray / (median_ray @ rotation[2]).clamp(min=1e-6)[..., None]  # at unit depth
    usable = (depth > median / DEPTH_RANGE**2)[..., None]
    unit_ray = torch.where(usable, ray / depth.clamp(min=1e-6)[..., None], median_ray)
    return torch.where((limited != depth)[..., None], center + unit_ray * limited[..., None], roots)


def antithetic_normal(count: int, generator: torch.Generator) -> torch.Tensor:
    """``count`` standard normal draws ``(count, 17, 3)`` in pairs z, -z, so that their median is zero to the last bit."""
    half = torch.randn(((count + 1) // 2, 17, 3), generator=generator)
    return torch.cat([half, -half])[:count]


class GuidedProblem:
    """The energy of a batch of windows: decoding, root placement and all energy terms.

    The state guided is ``x0`` (normalised windows, which fix the motion up to a
    shift) plus a world ``offset`` per frame. The offset is solved in closed form
    (per frame, smoothed) from each new network prediction; guidance steps then
    move both.
    """

    def __init__(
        self,
        prior: PriorBundle,
        obs: Observations,
        rays: RayConstraints | None,
        config: SamplerConfig,
        root_trajectory: torch.Tensor | None = None,
        anchor: Anchor | None = None,
        size_factors: torch.Tensor | None = None,
    ) -> None:
        if rays is None and root_trajectory is None:
            raise ValueError("either ray constraints (to solve the root) or a known root trajectory is needed")
        self.prior, self.obs, self.rays, self.config = prior, obs, rays, config
        self.root_trajectory = root_trajectory
        self.anchor = anchor
        self.size_factors = size_factors
        self.batch = obs.keypoints.shape[1]
        self.anchor_features: torch.Tensor | None = None
        self.std = torch.as_tensor(prior.normalizer.std, dtype=obs.keypoints.dtype, device=obs.keypoints.device)

    def local_joints(self, x0: torch.Tensor) -> torch.Tensor:
        """Normalised windows ``(B*N, F, D)`` -> joints ``(B, N, F, 17, 3)`` in the prior's frame."""
        joints = features_to_joints(self.prior.normalizer.denormalize(x0))
        return joints.reshape(self.batch, -1, *joints.shape[1:])

    def solve_offset(self, x0: torch.Tensor) -> torch.Tensor:
        """World offset ``(B, N, F, 3)`` of the windows: known root path, or the closed-form translation."""
        local = self.local_joints(x0)
        if self.root_trajectory is not None:
            return self.root_trajectory[:, None] - local[..., 0, :]
        placed = typical_size(local, self.size_factors) if self.config.size_prior else local
        offset = solve_translation(placed, self.rays, self.obs.cameras, self.config.translation_smoothness)
        if len(self.obs.cameras) == 1:  # a few poorly fitting early predictions fell towards the camera centre
            roots = local[..., 0, :]
            offset = limit_depth(roots + offset, self.obs.cameras.R[0], self.obs.cameras.t[0]) - roots
        if self.anchor is not None:  # continuation: start on the anchor, return to the rays' placement by the end
            continued = self.anchor.joints[..., :1, 0, :] - local[..., :1, 0, :]  # (B, N, 1, 3)
            ramp = continuation_ramp(self.anchor.mask)[:, None, :, None]
            offset = ramp * continued + (1 - ramp) * offset
        return offset

    def inpaint(self, x0: torch.Tensor) -> torch.Tensor:
        """Continue the anchor in ``x0`` ``(B*N, F, D)``: anchored frames take the anchor's features (RePaint-style),
        and the free frames are shifted by the gap at the last anchored frame, fading out by the window's end.

        Without the shift the network's own frames start where its prediction was, not where the
        anchor ends: with one camera the first free frame was 26 cm (median) from the last anchored one.
        """
        if self.anchor is None:
            return x0
        if self.anchor_features is None:
            joints = self.anchor.joints.reshape(-1, *self.anchor.joints.shape[2:])
            self.anchor_features = self.prior.normalizer.normalize(joints_to_features(joints))
        per_window = x0.shape[0] // self.batch
        mask = self.anchor.mask.repeat_interleave(per_window, dim=0)  # (B*N, F)
        last = (mask.sum(-1) - 1).clamp(min=0).long()  # the last anchored frame of each row
        rows = torch.arange(x0.shape[0], device=x0.device)
        gap = self.anchor_features[rows, last] - x0[rows, last]  # (B*N, D): features are affine in the joints
        fade = continuation_ramp(self.anchor.mask).repeat_interleave(per_window, dim=0)[..., None]
        return torch.where(mask[..., None] > 0, self.anchor_features, x0 + fade * gap[:, None, :])

    def world_joints(self, x0: torch.Tensor, offset: torch.Tensor) -> torch.Tensor:
        """World joints ``(B, N, F, 17, 3)``; with a known root path the pelvis is pinned to it."""
        local = self.local_joints(x0)
        if self.root_trajectory is not None:
            offset = self.root_trajectory[:, None] - local[..., 0, :]
        return local + offset[..., None, :]

    def displaced(self, start: torch.Tensor, moved: torch.Tensor) -> torch.Tensor:
        """World joints ``(3, B, N, F, 17)`` (component-first) after moving ``start`` by ``moved``; with a known
        root path each frame's pelvis stays on it (the joints move relative to it)."""
        if self.root_trajectory is not None:
            return start + (moved - moved[..., :1])
        return start + moved

    def absorb(self, x0: torch.Tensor, offset: torch.Tensor, moved: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Windows ``x0`` ``(B*N, F, D)`` and offsets ``(B, N, F, 3)`` holding the joints moved by ``moved``
        ``(3, B, N, F, 17)``: features are linear in joint moves up to one shift per window (frame 0's root),
        which the offset takes."""
        joints = moved.movedim(0, -1)  # (B, N, F, 17, 3)
        features = joints_to_features(joints).reshape(x0.shape) / self.std
        return x0 + features, offset + joints[:, :, :1, 0, :]

    def camera_frame(self) -> tuple[torch.Tensor, torch.Tensor] | None:
        """The camera's ``(R, t)`` (world -> camera) when guidance runs in its frame, else None (world frame).

        One camera with Gauss-Newton steps: its terms and each joint's 3x3 system are far cheaper in
        its axes, where the Jacobian rows are (1, 0, -u) and (0, 1, -v); every energy is the same there.
        """
        cameras = self.obs.cameras
        if len(cameras) == 1 and self.config.direction == "gauss-newton":
            return cameras.R[0], cameras.t[0]
        return None

    def depth_smoothed(self, start: torch.Tensor, moved: torch.Tensor, in_camera: bool) -> torch.Tensor:
        """One camera: the move ``(3, B, N, F, 17)`` from ``start`` after which every joint's depth path is smoothed
        (:mod:`lifting.depth_smoothing`); ``start`` and ``moved`` are in the camera's frame or (not ``in_camera``) the
        world's. Joints that are not finite (frames outside a given root path) keep ``moved``."""
        rotation, translation = self.obs.cameras.R[0], self.obs.cameras.t[0]
        joints = start + moved if in_camera else rigid_motion(start + moved, rotation, translation)
        anchored = None if self.anchor is None else self.anchor.mask
        smoothed = smooth_depth(joints, self.config.depth_smoothness, anchored)
        if not in_camera:
            smoothed = rigid_motion(smoothed, rotation.T, -rotation.T @ translation)
        smoothed_move = smoothed - start
        return torch.where(torch.isfinite(smoothed_move), smoothed_move, moved)  # frames without a root keep theirs

    def evaluate(self, joints: torch.Tensor, anchor: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """Energy per hypothesis ``(B*N,)`` and descent direction ``(3, B, N, F, 17)`` (a move of every joint,
        component-first) at joints ``joints`` ``(B, N, F, 17, 3)``; joints, ``anchor`` (the anchor's joints) and
        direction are in the guidance frame (:meth:`camera_frame`, else the world).

        "gradient": the joints' move for minus the gradient with respect to the windows' features
        (the paper's update). "gauss-newton": minus a damped Gauss-Newton step per joint in world
        space (the 3x3 reprojection curvature of each joint over all cameras); it converges in a
        few iterations where the plain gradient needs hundreds, and leaves the depth of a single
        view to the prior (no curvature there, only damping).
        """
        c = self.config
        in_camera = self.camera_frame() is not None
        energy, grad, curvature = reprojection_terms(joints, self.obs, c.robust, c.robust_scale, in_camera)
        energy, grad, curvature = self.add_extra_terms(joints, energy, grad, curvature, anchor)
        total = energy.sum(-1).reshape(-1)
        if c.direction == "gradient":
            return total, self.feature_gradient_move(grad)
        trace = curvature[0] + curvature[3] + curvature[5]  # (B, N, F, 17), the same in any axes
        damping = c.damping / 3 * trace.mean(dim=(-1, -2))  # mean curvature diagonal per hypothesis, (B, N)
        system = add_to_diagonal_(curvature, damping[..., None, None] + 1e-9)
        return total, solve_symmetric3(system, grad, scale=-1.0)  # (3, B, N, F, 17)

    def feature_gradient_move(self, grad: torch.Tensor) -> torch.Tensor:
        """The joints' move ``(3, B, N, F, 17)`` for a unit step along minus the features' gradient, given the
        joints' gradient ``grad`` ``(3, B, N, F, 17)`` (the decoding is affine: both are linear in ``grad``)."""
        B, N, F = grad.shape[1:4]
        offset = grad.new_zeros(B, N, F, 3)
        with torch.enable_grad():
            x = grad.new_zeros(B * N, F, self.prior.config.features, requires_grad=True)
            (grad_x,) = torch.autograd.grad(self.world_joints(x, offset), x, grad_outputs=grad.movedim(0, -1))
        return features_to_joints(grad_x * -self.std).reshape(B, N, F, -1, 3).movedim(-1, 0)

    def add_extra_terms(self, joints, energy, grad, curvature, anchor: torch.Tensor | None = None):
        """Add the structural energies (autograd, small) and the anchor (analytic) to the reprojection terms.

        ``grad`` ``(3, B, N, F, 17)`` and ``curvature`` ``(6, B, N, F, 17)`` are component-first, as
        :func:`lifting.energy.reprojection_terms` returns them, in the frame of ``joints`` and of
        ``anchor`` (the anchor's joints; both energies are the same in any rigid frame).
        """
        c = self.config
        if c.bone_weight > 0 or c.symmetry_weight > 0:
            with torch.enable_grad():
                j = joints.detach().requires_grad_(True)
                extra = c.bone_weight * bone_constancy_energy(j) + c.symmetry_weight * symmetry_energy(j)
                (extra_grad,) = torch.autograd.grad(extra.sum(), j)
            energy, grad = energy + extra.detach(), grad + extra_grad.movedim(-1, 0)
        if self.anchor is not None:  # isotropic curvature: the same in any axes
            mask = self.anchor.mask[:, None, :]
            gap = joints - anchor
            energy = energy + self.anchor.weight * mask * (gap**2).sum(dim=(-1, -2))
            grad = grad + (2 * self.anchor.weight * mask[..., None, None] * gap).movedim(-1, 0)
            curvature = add_to_diagonal_(curvature, 2 * self.anchor.weight * mask[..., None])
        return energy, grad, curvature

    def guide(self, x0: torch.Tensor, iterations: int) -> tuple[torch.Tensor, torch.Tensor]:
        """At most k guidance steps on ``x0`` ``(B*N, F, D)`` and its offset with the configured step rule.

        The steps move the joints (component-first, decoded once, in the guidance frame); the
        windows and offsets take the accepted move at the end. Guidance stops early once every
        hypothesis took a step gaining less than ``guidance_tol`` of its energy at the start (or
        cannot step any more).
        """
        c = self.config
        offset = self.solve_offset(x0)
        start = self.world_joints(x0, offset).movedim(-1, 0)  # (3, B, N, F, 17)
        anchor = None if self.anchor is None else self.anchor.joints
        frame = self.camera_frame()
        if frame is not None:
            start = rigid_motion(start, *frame)
            anchor = None if anchor is None else rigid_motion(anchor.movedim(-1, 0), *frame).movedim(0, -1)
        start = start.contiguous()
        moved = torch.zeros_like(start)
        rows = (1, self.batch, -1, 1, 1)  # one hypothesis per row of the component-first arrays
        step = torch.full((x0.shape[0],), c.energy_scale, dtype=x0.dtype, device=x0.device)
        energy, direction = self.evaluate(start.movedim(0, -1), anchor)
        initial = energy.abs().clamp(min=1e-12)
        for _ in range(iterations):
            candidate = torch.addcmul(moved, step.reshape(rows), direction)
            new_energy, new_direction = self.evaluate(self.displaced(start, candidate).movedim(0, -1), anchor)
            finite = torch.isfinite(new_energy) & torch.isfinite(new_direction.sum(dim=(0, 3, 4)).reshape(-1))
            worse = ~finite | (new_energy > energy)  # NaN and inf propagate into the sums
            accept = ~worse if c.step_rule == "backtrack" else torch.ones_like(worse)
            moved = _select_rows(accept, candidate, moved, rows)
            direction = _select_rows(accept, new_direction, direction, rows)
            gain = (energy - new_energy) / initial
            energy = torch.where(accept, new_energy, energy)
            grown = step * c.grow if c.step_rule == "backtrack" else step
            if c.direction == "gauss-newton":  # a Gauss-Newton step is whole at 1: longer only runs along the rays
                grown = grown.clamp(max=1.0)
            step = torch.where(worse, step * c.decay, grown)
            converged = (accept & (gain <= c.guidance_tol)) | (step < 1e-4 * c.energy_scale)
            if c.guidance_tol > 0 and bool(converged.all()):
                break  # every hypothesis took a step that gained less than the tolerance (or cannot step)
        if len(self.obs.cameras) == 1 and c.depth_smoothness > 0:
            moved = self.depth_smoothed(start, moved, in_camera=frame is not None)
        if frame is not None:  # the move back in world axes
            moved = rigid_motion(moved, frame[0].T)
        return self.absorb(x0, offset, moved)


def rigid_motion(points: torch.Tensor, rotation: torch.Tensor, translation: torch.Tensor | None = None) -> torch.Tensor:
    """``rotation @ p + translation`` for component-first points ``(3, ...)`` (one matrix product)."""
    flat = points.reshape(3, -1)
    moved = rotation @ flat if translation is None else torch.addmm(translation[:, None], rotation, flat)
    return moved.reshape(points.shape)


def _select_rows(accept: torch.Tensor, new: torch.Tensor, old: torch.Tensor, rows: tuple[int, ...]) -> torch.Tensor:
    """``where(accept, new, old)`` per hypothesis (``accept`` reshaped to ``rows``), without a full copy when all
    or none accept."""
    if bool(accept.all()):
        return new
    if not bool(accept.any()):
        return old
    return torch.where(accept.reshape(rows), new, old)


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
    model = prior.model
    dtype = obs.keypoints.dtype
    device = obs.keypoints.device
    schedule = DiffusionSchedule(prior.config.diffusion_steps)
    steps = sampling_steps(config.steps, config.skip, prior.config.diffusion_steps)
    generator = torch.Generator(device="cpu").manual_seed(config.seed)
    shape = (obs.keypoints.shape[1] * config.samples, frames, prior.config.features)
    noise = torch.randn(shape, generator=generator, dtype=torch.float32).to(device=device, dtype=dtype)
    sizes = (
        torch.exp(config.size_spread * torch.randn(config.samples, generator=generator))
        if config.size_spread > 0
        else None
    )
    draws = antithetic_normal(config.samples, generator)  # the noise spread's, one (17, 3) per hypothesis
    raw = obs  # the reported energy is against the keypoints as given
    if config.noise_fit and len(obs.cameras) == 1:  # guidance fits the keypoints' most likely paths
        obs = smooth_keypoints(obs, keypoint_noise(obs))
        rays = ray_constraints(obs) if rays is not None else None
    problem = GuidedProblem(prior, obs, rays, config, root_trajectory, anchor, sizes)
    x_t = schedule.add_noise(torch.zeros_like(noise), int(steps[0]), noise)
    x0 = x_t
    for i, t in enumerate(steps):
        with torch.inference_mode():
            x0 = model(x_t, torch.tensor(int(t), device=device))
        x0, offset = problem.guide(problem.inpaint(x0.clone()), config.guidance_iters)
        t_prev = int(steps[i + 1]) if i + 1 < len(steps) else None
        if t_prev is not None:  # the last prediction keeps its own overlap, pulled by the anchor energy, for blending
            x0 = problem.inpaint(x0)
        fresh = torch.randn(shape, generator=generator).to(device=device, dtype=dtype) if config.eta > 0 else None
        x_t = schedule.ddim_step(x_t, x0, int(t), t_prev, config.eta, fresh)
        if progress is not None:
            progress(i + 1, len(steps))
    with torch.no_grad():
        fitted, joints = settle_several_views(problem.world_joints(x0, offset), obs, draws, config, prior.fps)
        energy = reprojection_energy(joints, raw, config.robust, config.robust_scale)
    return SampleResult(joints.cpu().numpy(), energy.cpu().numpy(), fitted.cpu().numpy())


def settle_several_views(
    fitted: torch.Tensor, obs: Observations, draws: torch.Tensor, config: SamplerConfig, fps: float
) -> tuple[torch.Tensor, torch.Tensor]:
    """Several cameras: the guided fit ``(B, N, F, 17, 3)`` moved by the noise fit, and the hypotheses spread from it.

    Returns (fitted, hypotheses); with one camera, or both steps off, both are the fit as given.
    """
    if len(obs.cameras) < 2 or not (config.noise_fit or config.noise_spread):
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
