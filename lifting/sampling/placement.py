"""Where each new network prediction stands in the world: known root path, or the rays' closed-form placement.

The prior predicts motion up to a shift; every diffusion step's prediction is placed before
guidance moves it (:meth:`lifting.sampling.guidance.GuidedProblem.solve_offset`):

- size prior (:func:`typical_size`): one view cannot tell a small near person from a tall far
  one, so each prediction is brought to an adult size (each hypothesis its own) before the rays
  place it (:func:`lifting.sampling.translation.solve_translation`);
- depth limit (:func:`limit_depth`, one view): roots far nearer or farther than their window's
  median hypothesis come back along their rays;
- continuation (:class:`Anchor`, :func:`continuation_ramp`): a window that continues the one
  before starts on it and returns to the rays' own placement by its end.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from platypose.lifting.sampling.energy import bone_lengths_torch
from platypose.lifting.skeleton import SIZE_BONES, TYPICAL_BONE_LENGTHS

DEPTH_RANGE = 1.5  # one view: a root over this many times nearer or farther than the median hypothesis is moved back
SIZE_LIMITS = (0.5, 2.0)  # the size prior never scales a prediction by more than this
MIN_GAP_FRAMES = 6  # prior frames unseen right after a window's anchored ones: a gap the person reappears from
LANDING_RAMP = 8  # prior frames over which a window the floor contact places leaves the carried placement


@dataclass(frozen=True)
class Anchor:
    """Known joints for some frames of each hypothesis (window continuation).

    ``joints`` (B, N, F, 17, 3) world metres; ``mask`` (B, F) is 1 where a frame is
    anchored, 0 elsewhere, and frame 0 must be anchored. Anchored frames are in-painted
    (their features replace the prediction's at every step, so the network continues
    them) and held by an energy of ``weight`` per squared metre. ``seen`` (B, F), if given, is 1 on frames with
    keypoints in some view: the continued placement is kept until the first of them after the anchored frames
    (:func:`continuation_ramp`), so a window inside a detection gap carries the track on instead of placing it.
    ``landing`` (B,), if given (a floor), is True for windows the floor contact places (:func:`landing`: the person
    is back in them, or in the window before, after a gap; :meth:`lifting.sampling.grounding.Grounding.place`).
    """

    joints: torch.Tensor
    mask: torch.Tensor
    weight: float = 100.0
    seen: torch.Tensor | None = None
    landing: torch.Tensor | None = None


def continuation_ramp(mask: torch.Tensor, seen: torch.Tensor | None = None) -> torch.Tensor:
    """Weights ``(B, F)``: 1 over each row's anchored first frames, then falling linearly to 0 at the last frame.

    Blending the continued placement (weight 1) into the rays' own placement with
    these weights joins a window to the one before without letting the placement
    drift from window to window (with one camera, windows that only continue their
    predecessor drift, e.g. towards the camera). With ``seen`` (B, F), rows around a detection gap:

    - seen after its anchored frames, then a gap, then seen again: 0 from the gap's start, so the rays' smoothed
      placement, which has the person on both sides, takes the track across the gap (ramping over the whole window
      left the track 0.3-0.4 m behind in the gap, and it jumped where the person was seen again);
    - a gap right after the anchored frames: 0 from the first frame seen after it when the person is seen there
      for at least as many frames as the gap lasts in the window (the rays' placement, extrapolated back over the
      gap, then spans no more than its data: 0.28 m largest pelvis step of the Sports2D man against 0.59 m);
      otherwise 1 up to that frame, then falling to 0 at the last frame (extrapolated back from a few frames
      after the gap, the rays' placement stepped 13 m);
    - nothing seen after the anchored frames (a window inside a gap): 1 throughout, the track carried on.
    """
    F = mask.shape[-1]
    frames = torch.arange(F, dtype=mask.dtype, device=mask.device)
    last_held = (mask.sum(-1, keepdim=True) - 1).clamp(min=0)  # (B, 1)
    if seen is None:
        return ((F - 1 - frames) / (F - 1 - last_held).clamp(min=1)).clamp(0, 1)
    never = torch.full_like(frames, float(F))
    first_unseen = torch.where((seen <= 0) & (frames > last_held), frames, never).amin(-1, keepdim=True)
    back = torch.where((seen > 0) & (frames > first_unseen), frames, never).amin(-1, keepdim=True)
    seen_first = first_unseen > last_held + 1  # seen between the anchored frames and the gap
    after = ((seen > 0) & (frames >= back)).sum(-1, keepdim=True)  # frames seen after the gap
    reaches = after >= back - last_held  # the rays' placement extrapolated back no farther than its data spans
    carried = ~seen_first & ~reaches & (back < F)
    held = torch.where(carried, back - 1, last_held)  # the carried placement is kept up to here
    end = torch.where(seen_first & (back < F), first_unseen, torch.full_like(last_held, float(F - 1)))
    end = torch.where(~seen_first & reaches & (back < F), back, end)
    ramp = ((end - frames) / (end - held).clamp(min=1)).clamp(0, 1)
    ramp = torch.where(frames <= held, torch.ones_like(ramp), ramp)
    return torch.where(((seen > 0) & (frames > last_held)).any(-1, keepdim=True), ramp, torch.ones_like(ramp))


def reappearing(mask: torch.Tensor, seen: torch.Tensor | None, min_gap: int = 1) -> torch.Tensor:
    """Windows ``(B,)`` (bool) whose anchored frames (``mask`` ``(B, F)``) are followed by at least ``min_gap`` frames
    no camera sees, then by a frame some camera sees (``seen`` ``(B, F)``): the person reappears in them after a gap
    that began before them, so the placement they continue was carried across the gap by the prior alone."""
    if seen is None:
        return torch.zeros(mask.shape[0], dtype=torch.bool, device=mask.device)
    frames = torch.arange(mask.shape[-1], dtype=mask.dtype, device=mask.device)
    last_held = (mask.sum(-1, keepdim=True) - 1).clamp(min=0)  # (B, 1)
    back = torch.where((seen > 0) & (frames > last_held), frames, float(mask.shape[-1])).amin(-1)  # (B,)
    return (back < mask.shape[-1]) & (back - last_held[:, 0] - 1 >= min_gap)


def landing(mask: torch.Tensor, seen: torch.Tensor, seen_before: torch.Tensor) -> torch.Tensor:
    """Anchored windows ``(B,)`` the floor contact places (``mask``, ``seen`` as :func:`reappearing`; ``seen_before``
    ``(B, F)`` the frames seen in the window before each, none for a span's first): the person reappears in them after
    a gap, or did in the window before and is seen in them (their frames continue the carried placement, which the
    size prior would pull back towards a raised level)."""
    before = reappearing(mask, seen_before, MIN_GAP_FRAMES) & (seen > 0).any(-1)
    return reappearing(mask, seen, MIN_GAP_FRAMES) | before


def continued_offset(offset: torch.Tensor, local: torch.Tensor, anchor: Anchor) -> torch.Tensor:
    """Offsets ``(B, N, F, 3)`` of poses ``local`` ``(B, N, F, 17, 3)`` that start on the ``anchor``'s first
    pelvis and blend into ``offset`` (the rays' placement) by the window's end (:func:`continuation_ramp`).

    In a window the floor contact places (``anchor.landing``) the carried placement only bridges: it gives way
    linearly from the anchored frames to the first frame seen after them (at least ``LANDING_RAMP`` frames on),
    and the gap's frames before that take the rays' placement there, not their own (extrapolated back over
    the gap from one view, it moved the Sports2D man's hypotheses 8-16 m inside his gap). Likewise, where
    ``anchor.landing`` is given (a floor), the frames after the last one seen in a window (a gap it ends in) take
    the rays' placement of that frame and go on with the prior's motion from there, not the rays' own extrapolated
    over the gap."""
    continued = anchor.joints[..., :1, 0, :] - local[..., :1, 0, :]  # (B, N, 1, 3)
    ramp = continuation_ramp(anchor.mask, anchor.seen)
    F = ramp.shape[-1]
    frames = torch.arange(F, dtype=ramp.dtype, device=ramp.device)
    last_held = (anchor.mask.sum(-1, keepdim=True) - 1).clamp(min=0)  # (B, 1)
    if anchor.seen is not None and anchor.landing is not None:  # grounded: after the last frame seen, its placement
        last_seen = torch.where((anchor.seen > 0) & (frames > last_held), frames, -1.0).amax(-1, keepdim=True)
        at_last = offset.gather(2, last_seen.clamp(min=0).long()[:, None, :, None].expand(-1, offset.shape[1], 1, 3))
        trailing = (last_seen >= 0) & (frames > last_seen)
        offset = torch.where(trailing[:, None, :, None], at_last, offset)
    if anchor.landing is not None and anchor.seen is not None:
        back = torch.where((anchor.seen > 0) & (frames > last_held), frames, float(F - 1)).amin(-1, keepdim=True)
        end = torch.maximum(back, last_held + LANDING_RAMP)
        bridge = ((end - frames) / (end - last_held).clamp(min=1)).clamp(0, 1)
        landing = anchor.landing[:, None]
        ramp = torch.where(landing, bridge, ramp)
        at_back = offset.gather(2, back.long()[:, None, :, None].expand(-1, offset.shape[1], 1, 3))  # (B, N, 1, 3)
        offset = torch.where((landing & (frames < back))[:, None, :, None], at_back, offset)
    ramp = ramp[:, None, :, None]
    return ramp * continued + (1 - ramp) * offset


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
