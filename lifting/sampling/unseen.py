"""Guidance's correction carried over the joints no camera sees.

Guidance moves a joint only where a camera sees it (or the floor or an anchor holds it); the network's prediction of an
unseen stretch stays where it was. The seen frames on either side were moved, by several centimetres with one view, so
the motion stepped at a gap's edges: 100 mm per joint in one frame of the sampler's output, against 16 mm of real
motion, where a one-view window hid 30 of its 64 frames (``platypose eval --gap 1``). An unseen joint between two
known frames of its window now takes their moves, each fading over ``FADE_S`` (a correction fitted to one pose says
little about the pose half a stride later), shared where both are near. A stretch running to the window's edge
is left to the next window, which continues this one's motion.

The sampler bridges on its last step only: bridging on every step lifted inside the gap better still, but the network
then placed the Sports2D walker 0.1-0.15 m farther after her cut 1.5 s gap (docs/results.md).
"""

from __future__ import annotations

import torch

FADE_S = 0.5  # seconds over which a known frame's move fades into the unseen frames next to it


def bridged_moves(moved: torch.Tensor, known: torch.Tensor, fade_frames: float) -> torch.Tensor:
    """What to add to joint moves ``moved`` ``(3, B, N, F, J)`` (component-first; N hypotheses of B windows) on each
    joint unknown in ``known`` ``(B, F, J)`` with known frames on both sides in its window: the same joint's moves at
    the nearest known frame before and after, each weighted by ``1 - frames away / fade_frames`` (at least 0), the
    weights divided by their sum where it exceeds 1; 0 elsewhere (its own move, from the floor or the joint limits,
    stays on top)."""
    B, F, J = known.shape
    frames = torch.arange(F, device=moved.device).reshape(1, F, 1).expand(B, F, J)
    before = torch.where(known, frames, torch.full_like(frames, -1)).cummax(dim=1).values
    after = torch.where(known, frames, torch.full_like(frames, F)).flip(1).cummin(dim=1).values.flip(1)
    weight_before = (1 - (frames - before).to(moved.dtype) / fade_frames).clamp(min=0)
    weight_after = (1 - (after - frames).to(moved.dtype) / fade_frames).clamp(min=0)
    total = (weight_before + weight_after).clamp(min=1)
    shape = (1, B, 1, F, J)

    def weighted(index: torch.Tensor, weight: torch.Tensor) -> torch.Tensor:
        at = moved.gather(3, index.clamp(0, F - 1).reshape(shape).expand_as(moved))
        return at * (weight / total).reshape(shape)

    bridge = weighted(before, weight_before) + weighted(after, weight_after)
    between = (~known & (before >= 0) & (after < F)).reshape(shape)
    return torch.where(between, bridge, torch.zeros_like(moved))
