"""One camera: keep every joint's depth from jumping between frames, without moving it in the image.

A single view fixes each joint's ray, not its depth along it: the depth is the prior's. A
sharp prior commits to one reading of an ambiguous pose, and a hypothesis can switch from one
reading to the other (the torso leaning towards the camera, then away) within a frame or two.
The network makes those switches itself; guidance, which moves joints across the rays, cannot
see them. Measured effect: docs/results.md.

After each diffusion step's guidance, every joint's depth path ``z`` (camera frame) is
replaced by the minimiser of

    sum_f w_f (z'_f - z_f)^2 + s * sum_f (z'_{f+1} - 2 z'_f + z'_{f-1})^2

and the joint slides along its own ray to that depth, so its projection does not move. The
first term keeps the prior's depths (``w_f`` = 1, and 1e4 on frames anchored to the window
before), the second takes out what changes faster than a person moves: with ``s`` = 10 it
halves a depth change at 2.7 Hz (30 fps), passes slower ones and damps faster ones. The
network then continues from the smoothed windows, so the next prediction agrees with them.
"""

from __future__ import annotations

import torch

from platypose.lifting.sampling.linalg import acceleration_penalty

ANCHORED_WEIGHT = 1e4  # an anchored frame's depth barely moves
MIN_DEPTH = 0.05  # metres: a joint this near the camera (or behind it) keeps its place


def depth_smoother(smoothness: float, frames: int, anchored: torch.Tensor | None, batch: int) -> torch.Tensor:
    """The linear map ``(B, F, F)`` from each window's depth path to its smoothed path (see the module).

    ``anchored`` ``(B, F)`` is 1 on frames held to the window before (or None: none are).
    """
    weight = torch.ones(batch, frames, dtype=torch.float64)
    if anchored is not None:
        weight = weight + ANCHORED_WEIGHT * anchored.detach().double().cpu()
    system = torch.diag_embed(weight) + smoothness * acceleration_penalty(frames, torch.float64, torch.device("cpu"))
    return torch.linalg.solve(system, torch.diag_embed(weight))


def smooth_depth(points: torch.Tensor, smoothness: float, anchored: torch.Tensor | None = None) -> torch.Tensor:
    """Joints in the camera's frame, component-first ``(3, B, N, F, 17)``, moved along their rays to smoothed depths.

    Windows of fewer than 3 frames, and paths that come nearer the camera than ``MIN_DEPTH``, are
    returned as they are.
    """
    _, B, _, F, _ = points.shape
    if F < 3 or smoothness <= 0:
        return points
    smoother = depth_smoother(smoothness, F, anchored, B).to(points)
    depth = points[2]  # (B, N, F, 17)
    smoothed = torch.einsum("bgf,bnfj->bngj", smoother, depth)
    in_front = ((depth > MIN_DEPTH) & (smoothed > MIN_DEPTH)).all(dim=2, keepdim=True)  # per joint path
    ratio = torch.where(in_front, smoothed / depth.clamp(min=MIN_DEPTH), torch.ones_like(depth))
    return points * ratio
