"""The guidance problem: the energy of a batch of windows, their placement and the guidance steps on them.

The state guided is ``x0`` (normalised windows, which fix the motion up to a shift) plus a
world offset per frame (:mod:`lifting.sampling.placement`). Guidance moves the decoded joints by damped
Gauss-Newton (or the paper's gradient) steps on the reprojection energy plus the structural and
anchor terms, accepts or cuts each step, and writes the accepted move back into windows and offsets.
"""

from __future__ import annotations

from dataclasses import replace

import torch

from platypose.lifting.anatomy.hinges import limit_residuals
from platypose.lifting.prior.features import features_to_joints, joints_to_features
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.sampling.energy import (
    Observations,
    bone_constancy_energy,
    reprojection_terms,
    symmetry_energy,
)
from platypose.lifting.sampling.grounding import Grounding
from platypose.lifting.sampling.linalg import SYMMETRIC_PAIRS, add_to_diagonal_, rotate_translate, solve_symmetric3
from platypose.lifting.sampling.placement import Anchor, continuation_ramp, continued_offset, typical_size
from platypose.lifting.sampling.translation import RayConstraints, solve_translation
from platypose.lifting.sampling.unseen import FADE_S, bridged_moves
from platypose.lifting.sampling.views import OneView, SeveralViews, views_for
from platypose.lifting.settings import SamplerConfig


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
        *,
        root_trajectory: torch.Tensor | None = None,
        anchor: Anchor | None = None,
        size_factors: torch.Tensor | None = None,
        views: OneView | SeveralViews | None = None,
        stance_heights: torch.Tensor | None = None,
        floor_choices: torch.Tensor | None = None,
    ) -> None:
        if rays is None and root_trajectory is None:
            raise ValueError("either ray constraints (to solve the root) or a known root trajectory is needed")
        self.prior, self.obs, self.rays, self.config = prior, obs, rays, config
        self.views = views_for(obs.cameras) if views is None else views
        self.grounding = (
            None
            if config.floor is None
            else Grounding(config.floor, obs, config, prior.fps, stance_heights, floor_choices)
        )
        self.floor_state: tuple[torch.Tensor, torch.Tensor, float] | None = None  # stance, floor in guidance frame
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
        offset = self.views.limit_offset(local[..., 0, :], offset)
        anchor = self.anchor
        if anchor is not None and anchor.landing is not None:  # the floor contact places one view's landing
            landing = None if self.grounding is None else anchor.landing & self.grounding.single
            anchor = replace(anchor, landing=landing)
        if self.grounding is not None:  # windows seen by one camera: stance ankles' rays meet the floor
            offset = self.grounding.place(placed, offset, None if anchor is None else anchor.landing)
        if anchor is not None:  # continuation: start on the anchor, return to the rays' placement by the end
            offset = continued_offset(offset, local, anchor)
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

    def apply_joint_moves(
        self, x0: torch.Tensor, offset: torch.Tensor, moved: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Windows ``x0`` ``(B*N, F, D)`` and offsets ``(B, N, F, 3)`` holding the joints moved by ``moved``
        ``(3, B, N, F, 17)``: features are linear in joint moves up to one shift per window (frame 0's root),
        which the offset takes."""
        joints = moved.movedim(0, -1)  # (B, N, F, 17, 3)
        features = joints_to_features(joints).reshape(x0.shape) / self.std
        return x0 + features, offset + joints[:, :, :1, 0, :]

    def known_joints(self) -> torch.Tensor:
        """Joints ``(B, F, 17)`` that guidance measures: seen by a camera, or in an anchored frame."""
        known = (self.obs.confidence > 0).any(dim=0)
        if self.anchor is not None:
            known = known | (self.anchor.mask > 0)[..., None]
        return known

    def unseen_moves(self, moved: torch.Tensor, anchored: torch.Tensor | None) -> torch.Tensor:
        """What guidance's joint moves ``moved`` ``(3, B, N, F, 17)`` add on the joints no camera sees between seen
        ones (:func:`lifting.sampling.unseen.bridged_moves`): the pose's part of the moves (the pelvis is placement's),
        none from anchored frames (``anchored`` ``(B, F)``: the previous window's motion, blended in as it is)."""
        relative = moved - moved[..., :1]
        if anchored is not None:
            relative = relative * (anchored[None, :, None, :, None] == 0)
        return bridged_moves(relative, self.known_joints(), FADE_S * self.prior.fps)

    def camera_frame(self) -> tuple[torch.Tensor, torch.Tensor] | None:
        """The camera's ``(R, t)`` (world -> camera) when guidance runs in its frame, else None (world frame).

        One camera with Gauss-Newton steps (:meth:`lifting.sampling.views.OneView.guidance_frame`).
        """
        return self.views.guidance_frame(self.config)

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
        """Add the structural energies and the joint limits (:mod:`lifting.anatomy.hinges`; autograd, small), the floor's (:mod:`lifting.sampling.grounding`) and the anchor (analytic)
        to the reprojection terms.

        ``grad`` ``(3, B, N, F, 17)`` and ``curvature`` ``(6, B, N, F, 17)`` are component-first, as
        :func:`lifting.sampling.energy.reprojection_terms` returns them, in the frame of ``joints`` and of
        ``anchor`` (the anchor's joints; both energies are the same in any rigid frame).
        """
        c = self.config
        if c.bone_weight > 0 or c.symmetry_weight > 0:
            with torch.enable_grad():
                j = joints.detach().requires_grad_(True)
                extra = c.bone_weight * bone_constancy_energy(j) + c.symmetry_weight * symmetry_energy(j)
                (extra_grad,) = torch.autograd.grad(extra.sum(), j)
            energy, grad = energy + extra.detach(), grad + extra_grad.movedim(-1, 0)
        if c.limit_weight > 0:
            limit, limit_grad, limit_curvature = limit_terms(joints, c.limit_weight)
            energy, grad, curvature = energy + limit, grad + limit_grad, curvature + limit_curvature
        if self.floor_state is not None:
            energy, grad, curvature = self.grounding.add_terms(joints, energy, grad, curvature, *self.floor_state)
        if self.anchor is not None:  # isotropic curvature: the same in any axes
            mask = self.anchor.mask[:, None, :]
            gap = joints - anchor
            energy = energy + self.anchor.weight * mask * (gap**2).sum(dim=(-1, -2))
            grad = grad + (2 * self.anchor.weight * mask[..., None, None] * gap).movedim(-1, 0)
            curvature = add_to_diagonal_(curvature, 2 * self.anchor.weight * mask[..., None])
        return energy, grad, curvature

    def guide(
        self, x0: torch.Tensor, iterations: int, bridge_unseen: bool = False
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """At most k guidance steps on ``x0`` ``(B*N, F, D)`` and its offset with the configured step rule.

        The steps move the joints (component-first, decoded once, in the guidance frame); the
        windows and offsets take the accepted move at the end. Guidance stops early once every
        hypothesis took a step gaining less than ``guidance_tol`` of its energy at the start (or
        cannot step any more). ``bridge_unseen``: the joints no camera sees between seen ones take the moves of
        their seen neighbours (:meth:`unseen_moves`; the sampler's last step).
        """
        c = self.config
        offset = self.solve_offset(x0)
        start = self.world_joints(x0, offset).movedim(-1, 0)  # (3, B, N, F, 17)
        anchor = None if self.anchor is None else self.anchor.joints
        frame = self.camera_frame()
        if frame is not None:
            start = rotate_translate(start, *frame)
            anchor = None if anchor is None else rotate_translate(anchor.movedim(-1, 0), *frame).movedim(0, -1)
        start = start.contiguous()
        if self.grounding is not None:  # stance detected per hypothesis from where guidance starts
            self.floor_state = self.grounding.stance_and_floor(start.movedim(0, -1), *(frame or (None, None)))
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
        anchored = None if self.anchor is None else self.anchor.mask
        smoothed_move = self.views.depth_smoothed_move(start, moved, frame is not None, anchored, c)
        held = torch.zeros_like(moved[:1], dtype=torch.bool)  # joints the floor holds where guidance put them
        if self.floor_state is not None:  # standing ankles stay where guidance held them, no joint sinks further
            stance, normal, level = self.floor_state
            held = self.grounding.standing_joints(stance) | self.grounding.pushed_below_floor(
                start, moved, smoothed_move, normal, level
            )
            smoothed_move = torch.where(held, moved, smoothed_move)
        moved = smoothed_move
        if bridge_unseen:
            moved = moved + torch.where(held, 0.0, self.unseen_moves(moved, anchored))
        if frame is not None:  # the move back in world axes
            moved = rotate_translate(moved, frame[0].T)
        return self.apply_joint_moves(x0, offset, moved)


def limit_terms(joints: torch.Tensor, weight: float) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``weight`` times the joint limits' energy ``(...)`` of joints ``(..., 17, 3)`` (:func:`lifting.anatomy.hinges.limit_residuals`
    squared), its gradient ``(3, ..., 17)`` and its Gauss-Newton curvature ``(6, ..., 17)`` (``2 J^T J`` per joint,
    packed), component-first. Without the curvature a step would divide the limit's pull by the reprojection's
    curvature alone, nearly nothing along one view's rays: the step runs away in depth and backtracking stalls it.
    """
    with torch.enable_grad():
        j = joints.detach().requires_grad_(True)
        residuals = limit_residuals(j)
        count = residuals.shape[-1]
        jacobians = [
            torch.autograd.grad(residuals[..., k].sum(), j, retain_graph=k < count - 1)[0] for k in range(count)
        ]
    residuals = residuals.detach()
    grad = sum(2 * weight * residuals[..., k, None, None] * jacobians[k] for k in range(count))
    curvature = torch.stack(
        [sum(2 * weight * jac[..., a] * jac[..., b] for jac in jacobians) for a, b in SYMMETRIC_PAIRS]
    )
    return weight * (residuals**2).sum(-1), grad.movedim(-1, 0), curvature


def _select_rows(accept: torch.Tensor, new: torch.Tensor, old: torch.Tensor, rows: tuple[int, ...]) -> torch.Tensor:
    """``where(accept, new, old)`` per hypothesis (``accept`` reshaped to ``rows``), without a full copy when all
    or none accept."""
    if bool(accept.all()):
        return new
    if not bool(accept.any()):
        return old
    return torch.where(accept.reshape(rows), new, old)
