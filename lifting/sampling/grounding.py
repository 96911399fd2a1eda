"""Grounding inside the sampler: the floor as energies in guidance and as a constraint on the closed-form placement.

Given a floor ``n . x + d = 0`` (world metres, ``n`` up; :mod:`lifting.floor`):

- placement (:meth:`Grounding.place`): a window seen by one camera only is placed by the size prior,
  which leaves its depth and size to one typical adult. Scaling the placed motion about that camera's
  centre keeps every projection and changes depth and size together; the scale that puts the stance
  ankles (the lower ankle of slow frames, median over the window) at their stance height above the
  floor fixes both, and follows their own scales' line over the window (:func:`scale_trend`, at most
  ``TREND_LIMIT``): the size prior places each frame by the person's size in the image. The stance
  height is ``ANKLE_HEIGHT`` plus a draw of ``support_spread`` per hypothesis: shoes, mats, force plates
  and where a detector puts the ankle differ by centimetres, and each centimetre moves a one-view
  placement by several.
  Support is a prior, not a clamp: where one image cannot tell a near person on the floor from a far
  one on a step, both readings are kept as hypotheses. Every hypothesis takes the floor reading where
  it brings the person nearer (the size prior's feet were under the floor) or sizes them up by less
  than ``SURE_SCALE``, none where it sizes them up by more than ``MAX_SCALE`` (a person on a roof or a
  platform, a climber on a wall), a share in between (each hypothesis's own uniform draw against it);
  airborne windows and stance ankles above the camera keep the size prior's placement.
- energies (:meth:`Grounding.add_terms`), per hypothesis, in the guidance frame: penetration (every
  joint below the floor, ``floor_weight`` per squared metre, however many cameras see it); and on ankles
  whose depth one view alone fixes (:meth:`Grounding.one_view_ankles`), contact (stance ankles held at
  their stance height, ``contact_weight``) and sliding (a stance ankle's distance along the floor from
  where it stands over its run of stance frames, ``slide_weight``). Several cameras apart measure the feet
  themselves (an ankle rolls over its stance; pinning it cost 4-view accuracy). Stance is detected from
  each hypothesis itself (:meth:`Grounding.stance`, the rule of :mod:`lifting.stance` on tensors): its lower ankle,
  slower than ``STANCE_SPEED`` or still in the image. Sliding holds stance ankles wherever they stand (a roof too); contact pulls only
  those within ``CONTACT_BAND`` of their stance height on the floor. One view's depth smoothing after
  guidance leaves stance ankles where guidance held them and sinks no joint under the floor
  (:meth:`Grounding.pushed_below_floor`).
"""

from __future__ import annotations

import math

import torch

from platypose.lifting.sampling.energy import Observations
from platypose.lifting.sampling.linalg import SYMMETRIC_PAIRS
from platypose.lifting.sampling.placement import SIZE_LIMITS
from platypose.lifting.stance import ANKLE_HEIGHT, ANKLES, STANCE_SPEED

TYPICAL_EXTENT = 1.7  # metres: the diagonal of an adult's keypoints' box, standing (scales image speeds to m/s)
MIN_RAY_ANGLE = 5.0  # degrees: cameras whose rays to a joint meet at less than this measure it as one view does
CONTACT_BAND = 0.1  # metres: a stance ankle this far from ANKLE_HEIGHT is not standing on the floor
SURE_SCALE = 1.15  # a floor reading that sizes a person up by less than this: every hypothesis takes it
MAX_SCALE = 1.4  # by more than this: none (a raised support); in between a share falling linearly in log scale
MIN_DROP = 0.05  # metres: a stance ankle must be this far below the camera for its ray to meet the floor
LANDING_QUANTILE = 0.25  # of the lower ankle's floor scales after a gap: the frames it stands on the floor
TREND_LIMIT = 0.3  # a window's floor reading changes over its frames by at most this much in log scale (either way)


class Grounding:
    """The floor's terms for a batch of windows seen through ``obs`` (see the module)."""

    def __init__(
        self,
        plane: tuple[float, float, float, float],
        obs: Observations,
        weights,
        fps: float,
        stance_heights: torch.Tensor | None = None,
        choices: torch.Tensor | None = None,
    ) -> None:
        dtype, device = obs.keypoints.dtype, obs.keypoints.device
        heights = torch.zeros(1) if stance_heights is None else stance_heights
        self.stance_height = (ANKLE_HEIGHT + heights.to(dtype=dtype, device=device)).reshape(1, -1, 1, 1)  # per hyp.
        self.normal = torch.tensor(plane[:3], dtype=dtype, device=device)
        self.offset = float(plane[3])
        self.weights, self.fps = weights, fps
        cameras = obs.cameras
        self.centers = -torch.einsum("cij,ci->cj", cameras.R, cameras.t)  # (C, 3) camera centres in the world
        seen = (obs.confidence > 0).flatten(2).any(-1)  # (C, B): which cameras see each window
        self.single = seen.sum(0) == 1  # (B,) windows seen by exactly one camera
        self.viewer = seen.float().argmax(0)  # (B,) that camera (meaningless where not single)
        self.ankle_views = obs.confidence[..., list(ANKLES)] > 0  # (C, B, F, 2): the cameras seeing each ankle
        self.image_still = image_still_ankles(obs, fps)  # (B, F, 2)
        self.choices = (torch.full((1,), 0.5) if choices is None else choices).to(dtype=dtype, device=device)[None]

    def frame(self, rotation: torch.Tensor | None, translation: torch.Tensor | None) -> tuple[torch.Tensor, float]:
        """The floor ``(normal, offset)`` in the guidance frame ``x_c = R x + t`` (world if ``rotation`` is None)."""
        if rotation is None:
            return self.normal, self.offset
        normal = rotation @ self.normal
        return normal, self.offset - float(normal @ translation)

    def stance_and_floor(
        self, joints: torch.Tensor, rotation: torch.Tensor | None, translation: torch.Tensor | None
    ) -> tuple[torch.Tensor, torch.Tensor, float]:
        """(stance, normal, offset) for guidance at joints ``(B, N, F, 17, 3)`` in the frame ``x_c = R x + t`` (world if
        ``rotation`` is None): the floor there and the stance ankles that contact and sliding hold, those whose depth
        one view alone fixes (:meth:`one_view_ankles`: several views measure the feet themselves)."""
        normal, offset = self.frame(rotation, translation)
        centers = self.centers if rotation is None else self.centers @ rotation.T + translation
        stance = self.stance(joints, normal, offset) * self.one_view_ankles(joints, centers)
        return stance, normal, offset

    def stance(self, joints: torch.Tensor, normal: torch.Tensor, offset: float, image: bool = True) -> torch.Tensor:
        """Stance ankles ``(B, N, F, 2)`` (1 standing, 0 not) of joints ``(B, N, F, 17, 3)``: the lower ankle of each
        frame, slower than ``STANCE_SPEED`` along the floor (on the floor or on a raised support), or, with
        ``image``, still in the image (:func:`image_still_ankles`: one view's depth jitter moves a hypothesis's
        ankle along its ray, which the image does not see; the placement does not use it, which cost held-out
        accuracy)."""
        ankles = joints[..., list(ANKLES), :]  # (B, N, F, 2, 3)
        height = ankles @ normal + offset  # (B, N, F, 2)
        lower = height == height.min(dim=-1, keepdim=True).values
        stance = lower & torch.isfinite(height)
        if ankles.shape[2] > 1:
            step = ankles.diff(dim=2)
            along = step - (step @ normal)[..., None] * normal
            speed = along.norm(dim=-1) * self.fps
            speed = torch.cat([speed[:, :, :1], torch.minimum(speed[:, :, 1:], speed[:, :, :-1]), speed[:, :, -1:]], 2)
            stance = stance & ((speed < STANCE_SPEED) | (self.image_still[:, None] & image))
        return stance.to(joints.dtype)

    def one_view_ankles(self, joints: torch.Tensor, centers: torch.Tensor) -> torch.Tensor:
        """Ankles ``(B, N, F, 2)`` (1, else 0) of joints ``(B, N, F, 17, 3)`` whose depth no two views measure: seen
        by at most one camera, or by cameras (centres ``(C, 3)``, in the joints' frame) whose rays to it meet at
        less than ``MIN_RAY_ANGLE``."""
        ankles = joints[..., list(ANKLES), :]  # (B, N, F, 2, 3)
        rays = ankles[None] - centers[:, None, None, None, None, :]  # (C, B, N, F, 2, 3)
        rays = rays / rays.norm(dim=-1, keepdim=True).clamp(min=1e-9)
        seeing = self.ankle_views[:, :, None]  # (C, B, 1, F, 2)
        measured = torch.zeros(ankles.shape[:-1], dtype=torch.bool, device=joints.device)
        cosine = math.cos(math.radians(MIN_RAY_ANGLE))
        for i in range(len(centers)):
            for k in range(i + 1, len(centers)):
                apart = (rays[i] * rays[k]).sum(-1) < cosine
                measured = measured | (apart & seeing[i] & seeing[k])
        return (~measured).to(joints.dtype)

    def standing_joints(self, stance: torch.Tensor) -> torch.Tensor:
        """Boolean ``(1, B, N, F, 17)`` (component-first broadcast): the stance ankles of ``stance`` ``(B, N, F, 2)``."""
        joints = stance.new_zeros(*stance.shape[:-1], 17).index_add(-1, _ankle_index(stance), stance)
        return (joints > 0)[None]

    @staticmethod
    def pushed_below_floor(
        start: torch.Tensor, moved: torch.Tensor, smoothed_move: torch.Tensor, normal: torch.Tensor, offset: float
    ) -> torch.Tensor:
        """Boolean ``(1, B, N, F, 17)``: joints that the move ``smoothed_move`` (after guidance's ``moved``, both from
        ``start``, component-first ``(3, B, N, F, 17)``) puts below the floor ``(normal, offset)`` and below where
        ``moved`` left them (one view's depth smoothing runs along rays that slope down to the floor)."""
        guided = torch.einsum("c...,c->...", start + moved, normal) + offset
        smoothed = torch.einsum("c...,c->...", start + smoothed_move, normal) + offset
        return (smoothed < guided.clamp(max=0.0))[None]

    def place(self, placed: torch.Tensor, offset: torch.Tensor, reappears: torch.Tensor | None = None) -> torch.Tensor:
        """Offsets ``(B, N, F, 3)`` of the placed poses ``placed`` ``(B, N, F, 17, 3)`` (world, before the offset),
        rescaled about the camera of windows seen by one camera so that their stance ankles stand on the floor.

        In windows where the person ``reappears`` ``(B,)`` after a gap (:func:`lifting.sampling.placement.reappearing`)
        every hypothesis takes the floor reading of the frames seen (:meth:`landing_scale`): the level carried across
        the gap is no evidence of a raised support, and a person landing from a drop, crouched and half seen, is
        sized too small by the size prior (the Sports2D roof man stood 0.6 m above the floor after his gap)."""
        if not bool(self.single.any()):
            return offset
        world = placed + offset[..., None, :]
        center = self.centers[self.viewer][:, None, None, :]  # (B, 1, 1, 3)
        stance = self.stance(world, self.normal, self.offset, image=False) > 0  # (B, N, F, 2)
        ankles = world[..., list(ANKLES), :]
        drop = (ankles - center[..., None, :]) @ self.normal  # (B, N, F, 2): below the camera is negative
        camera_height = center[..., 0, :] @ self.normal + self.offset  # (B, 1)
        scale = (self.stance_height - camera_height[..., None, None]) / drop.clamp(max=-MIN_DROP)
        frames = placed.shape[2]
        usable = stance & (drop < -MIN_DROP)
        enough = usable.flatten(2).sum(-1) >= max(1, math.ceil(0.25 * frames))
        window_scale = torch.nan_to_num(torch.where(usable, scale, torch.nan).flatten(2).nanmedian(-1).values, nan=1.0)
        log_scale = window_scale.log().clamp(min=0)  # nearer than the size prior's: its feet were under the floor
        share = ((math.log(MAX_SCALE) - log_scale) / (math.log(MAX_SCALE) - math.log(SURE_SCALE))).clamp(0, 1)
        if reappears is not None and bool((reappears & self.single).any()):
            after_gap = (reappears & self.single)[:, None]  # (B, 1)
            landed, landed_enough = self.landing_scale(drop, scale)
            window_scale = torch.where(after_gap, landed, window_scale)
            enough = torch.where(after_gap, landed_enough, enough)
            share = torch.where(after_gap, torch.ones_like(share), share)
        floor_reading = enough & (self.choices < share) & self.single[:, None]  # (B, N)
        frame_scale = window_scale[..., None] * scale_trend(torch.where(usable, scale, torch.nan))  # (B, N, F)
        frame_scale = torch.where(floor_reading[..., None], frame_scale, torch.ones_like(frame_scale))
        root = world[..., 0, :]
        moved_root = center + frame_scale[..., None] * (root - center)
        return offset + (moved_root - root)

    def landing_scale(self, drop: torch.Tensor, scale: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Per hypothesis of a window where the person reappears after a gap, the scale ``(B, N)`` that puts the lower
        ankle on the floor, and whether it is known ``(B, N)``: over the frames whose lower ankle a camera sees below
        it (``drop`` ``(B, N, F, 2)`` below the camera, ``scale`` ``(B, N, F, 2)`` per ankle), the
        ``LANDING_QUANTILE`` of the lower ankle's (a foot on the floor needs the least scale; running, landing or
        crouched, one that stands slowly may be missing), within the size prior's ``SIZE_LIMITS`` (an ankle barely
        below the camera asked for 18 times), known where a quarter of the frames seen count."""
        lower = drop == drop.min(dim=-1, keepdim=True).values  # the lower ankle (the farther below the camera)
        seen = self.ankle_views.any(0)[:, None]  # (B, 1, F, 2)
        usable = lower & seen & (drop < -MIN_DROP)
        per_frame = torch.where(usable, scale, torch.nan).flatten(2)  # (B, N, 2F)
        frames_seen = seen.any(-1).sum(-1)  # (B, 1)
        known = usable.flatten(2).sum(-1) >= (0.25 * frames_seen).ceil().clamp(min=1)
        landed = torch.nan_to_num(per_frame.nanquantile(LANDING_QUANTILE, dim=-1), nan=1.0).clamp(*SIZE_LIMITS)
        return landed, known

    def add_terms(
        self,
        joints: torch.Tensor,
        energy: torch.Tensor,
        grad: torch.Tensor,
        curvature: torch.Tensor,
        stance: torch.Tensor,
        normal: torch.Tensor,
        offset: float,
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Add penetration, contact and sliding to energy ``(B, N, F)``, gradient ``(3, B, N, F, 17)`` and packed
        curvature ``(6, B, N, F, 17)`` at joints ``(B, N, F, 17, 3)`` with stance ankles ``stance`` ``(B, N, F, 2)``,
        all in the frame of the floor ``(normal, offset)``."""
        w = self.weights
        height = joints @ normal + offset  # (B, N, F, 17)
        below = height.clamp(max=0.0)
        slope = 2 * w.floor_weight * below  # d energy / d height
        stiffness = 2 * w.floor_weight * (height < 0).to(height.dtype)
        energy = energy + w.floor_weight * (below**2).sum(-1)
        ankle_gap = height[..., list(ANKLES)] - self.stance_height  # (B, N, F, 2)
        on_floor = stance * (ankle_gap.abs() < CONTACT_BAND).to(stance.dtype)  # stance on a raised support: no pull
        energy = energy + w.contact_weight * (on_floor * ankle_gap**2).sum(-1)
        ankle_slope = 2 * w.contact_weight * on_floor * ankle_gap
        slope = slope.index_add(-1, _ankle_index(joints), ankle_slope)
        stiffness = stiffness.index_add(-1, _ankle_index(joints), 2 * w.contact_weight * on_floor)
        grad = grad + slope.unsqueeze(0) * normal.reshape(3, 1, 1, 1, 1)
        curvature = _add_outer(curvature, normal, stiffness)
        if joints.shape[2] > 1 and w.slide_weight > 0:
            energy, grad, curvature = self._add_sliding(joints, energy, grad, curvature, stance, normal)
        return energy, grad, curvature

    def _add_sliding(self, joints, energy, grad, curvature, stance, normal):
        """The sliding term: ``slide_weight`` times each stance ankle's squared distance along the floor from its
        mean over its stance (a run of consecutive stance frames). Its gradient is exact without the means'
        derivatives (the distances sum to zero over a run), so one Gauss-Newton step reaches the mean."""
        w = self.weights.slide_weight
        ankles = joints[..., list(ANKLES), :].movedim(-2, 2)  # (B, N, 2, F, 3)
        standing = stance.movedim(-1, 2)  # (B, N, 2, F)
        frames = standing.shape[-1]
        starts = standing.clone()
        starts[..., 1:] = standing[..., 1:] * (1 - standing[..., :-1])
        run = starts.cumsum(-1).long()  # run number per frame, counted within each ankle's path
        series = torch.arange(run[..., 0].numel(), device=joints.device).reshape(run.shape[:-1])[..., None]
        index = (series * (frames + 1) + run).flatten()
        size = run[..., 0].numel() * (frames + 1)
        weight = standing.flatten()
        sums = joints.new_zeros(size, 3).index_add(0, index, ankles.reshape(-1, 3) * weight[:, None])
        counts = joints.new_zeros(size).index_add(0, index, weight)
        mean = (sums / counts.clamp(min=1)[:, None])[index].reshape(ankles.shape)
        gap = ankles - mean
        along = gap - (gap @ normal)[..., None] * normal  # (B, N, 2, F, 3)
        energy = energy + w * (standing[..., None] * along**2).sum(dim=(-1, 2)).reshape(energy.shape)
        ankle_grad = (2 * w * standing[..., None] * along).movedim(2, -2)  # (B, N, F, 2, 3)
        grad = grad + torch.zeros_like(joints).index_add(-2, _ankle_index(joints), ankle_grad).movedim(-1, 0)
        stiffness = torch.zeros_like(joints[..., 0]).index_add(-1, _ankle_index(joints), 2 * w * stance)
        curvature = _add_outer(curvature, normal, -stiffness)  # 2 w (I - n n^T) on stance ankles
        for entry, (k, m) in zip(curvature, SYMMETRIC_PAIRS):
            if k == m:
                entry.add_(stiffness)
        return energy, grad, curvature


def _ankle_index(joints: torch.Tensor) -> torch.Tensor:
    """The ankles' joint indices as a tensor on ``joints``' device."""
    return torch.tensor(ANKLES, device=joints.device)


def _add_outer(curvature: torch.Tensor, normal: torch.Tensor, scale: torch.Tensor) -> torch.Tensor:
    """``curvature + scale * n n^T`` for packed curvature ``(6, ...)`` and ``scale`` ``(...)``."""
    outer = torch.stack([normal[k] * normal[m] for k, m in SYMMETRIC_PAIRS]).reshape(6, *([1] * scale.dim()))
    return curvature + outer * scale.unsqueeze(0)


def scale_trend(stance_scales: torch.Tensor) -> torch.Tensor:
    """Per frame ``(B, N, F)``, the factor that turns a window's floor reading (the median over its stance ankles)
    into a line over its frames: the exponential of a line fitted (least squares) to the logs of its stance ankles'
    own floor scales ``(B, N, F, 2)`` (NaN where an ankle does not stand) over time, less their median. The line
    changes by at most ``TREND_LIMIT`` over the window; 1 throughout where fewer than a quarter of the frames (or
    two) stand.

    The size prior places each frame by the person's size in the image, so where that grows while the feet stay on
    one image row (the Sports2D walker crossing the lawn; a detector's keypoints spreading as a person turns), one
    reading per window left the feet rising off the floor by 10 cm within it; the line lets the stance feet's rays
    meet the floor in every frame, and keeps the size prior's frame-to-frame placement around it. The line's own
    level (its mean over the stance frames) replaces the median: keeping the median and only tilting it measured
    0.1-1.1 mm worse on every ``eval`` row and left the walker's feet less level (docs/results.md)."""
    logs = stance_scales.log()
    F = logs.shape[2]
    stands = torch.isfinite(logs)
    weight = stands.to(logs.dtype)
    count = weight.sum((-1, -2))  # (B, N)
    frames = torch.arange(F, dtype=logs.dtype, device=logs.device)
    mean_frame = (weight * frames[:, None]).sum((-1, -2)) / count.clamp(min=1)
    mean_log = (weight * torch.nan_to_num(logs)).sum((-1, -2)) / count.clamp(min=1)
    apart = weight * (frames[:, None] - mean_frame[..., None, None])  # (B, N, F, 2)
    slope = (apart * torch.nan_to_num(logs - mean_log[..., None, None])).sum((-1, -2)) / (apart**2).sum((-1, -2)).clamp(
        min=1e-9
    )
    slope = slope.clamp(-TREND_LIMIT / F, TREND_LIMIT / F)
    line = mean_log[..., None] + slope[..., None] * (frames - mean_frame[..., None])
    median = torch.nan_to_num(logs.flatten(2).nanmedian(-1).values)
    fitted = count >= max(2, math.ceil(0.25 * F))
    return torch.where(fitted[..., None], line - median[..., None], torch.zeros_like(line)).exp()


def image_still_ankles(obs: Observations, fps: float) -> torch.Tensor:
    """Ankles ``(B, F, 2)`` that stand still in the image: seen, and moving (the slower of the steps before and after,
    in the camera seeing them best) slower than ``STANCE_SPEED`` at the person's scale in the image, the diagonal
    of their keypoints' box (the window's 90th percentile over frames) taken as ``TYPICAL_EXTENT``."""
    points, confidence = obs.normalized, obs.confidence  # (C, B, F, 17, 2), (C, B, F, 17)
    seen = confidence > 0
    low = torch.where(seen[..., None], points, torch.inf).amin(dim=-2)
    high = torch.where(seen[..., None], points, -torch.inf).amax(dim=-2)
    diagonal = torch.where(seen.sum(-1) >= 4, (high - low).norm(dim=-1), torch.nan)  # (C, B, F)
    extent = diagonal.nanquantile(0.9, dim=-1)  # (C, B)
    best = confidence[..., list(ANKLES)].argmax(dim=0, keepdim=True)  # (1, B, F, 2): the camera seeing best
    ankles = points[..., list(ANKLES), :].gather(0, best[..., None].expand(1, *best.shape[1:], 2))[0]
    visible = seen[..., list(ANKLES)].gather(0, best)[0]  # (B, F, 2)
    scale = extent[..., None, None].expand(-1, -1, *best.shape[2:]).gather(0, best)[0]  # (B, F, 2)
    if ankles.shape[1] < 2:
        return torch.zeros_like(visible)
    step = ankles.diff(dim=1).norm(dim=-1)  # (B, F-1, 2)
    step = torch.where(visible[:, 1:] & visible[:, :-1], step, torch.inf)
    step = torch.cat([step[:, :1], torch.minimum(step[:, 1:], step[:, :-1]), step[:, -1:]], 1)
    speed = step / scale * TYPICAL_EXTENT * fps  # m/s at an adult's size
    return visible & (speed < STANCE_SPEED)
