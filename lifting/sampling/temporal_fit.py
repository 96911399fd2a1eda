"""Noisy 2D: the motion follows the keypoints only as far as their noise allows.

Guidance fits every frame to its keypoints exactly, so their noise goes straight into the
motion as jitter (docs/results.md). As estimation, the output should be the most likely motion under the keypoints' noise sigma
and a prior on how fast joints accelerate: minimise

    E_data(x) + sum_j (sigma^2 / a_j^2) sum_t |x_j(t+1) - 2 x_j(t) + x_j(t-1)|^2

(E_data the confidence-weighted squared reprojection error in normalised image units, a_j
the joint's RMS acceleration per frame squared in the bundled mocap). sigma is measured from
the keypoints themselves: the second differences of a noisy track have variance 6 sigma^2
plus the motion's own, and their median absolute value is robust to the motion's rare large
accelerations. Exact keypoints give sigma near 0 and leave the fit as it was.

With one camera the 3D fit is not used: depth has no data term to hold it, and the
acceleration prior straightens the unseen depth paths (less accurate, docs/results.md). There
the keypoints' own paths are smoothed the same way before guidance (:func:`smooth_keypoints`),
and the depth stays the prior's.
"""

from __future__ import annotations

import torch

from platypose.lifting.sampling.energy import Observations, reprojection_terms
from platypose.lifting.sampling.linalg import acceleration_penalty, second_difference, solve_smoothed, unpack_symmetric
from platypose.lifting.skeleton import TYPICAL_ACCELERATIONS

MAD_TO_SIGMA = 1.4826  # median absolute deviation -> standard deviation of a normal distribution


def keypoint_noise(obs: Observations) -> torch.Tensor:
    """Noise ``(B,)`` of each window's keypoints per coordinate, normalised image units, from their second differences.

    Only triples of consecutive frames where the keypoint is seen count; a window with none gets 0.
    """
    coords = obs.keypoints * obs.pixel_scale.reshape(-1, 1, 1, 1, 1)  # (C, B, F, 17, 2)
    second, valid = _seen_second_differences(coords, obs.confidence > 0)
    values = torch.where(valid[..., None], second.abs(), torch.nan).transpose(0, 1).flatten(1)  # (B, ...)
    if values.shape[1] == 0:  # under three frames
        return values.new_zeros(values.shape[0])
    return torch.nan_to_num(MAD_TO_SIGMA * values.nanmedian(dim=1).values / 6**0.5, nan=0.0)


def _seen_second_differences(coords: torch.Tensor, seen: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Second differences over frames of keypoint coordinates ``(C, B, F, 17, 2)``, and where all three frames of
    each are ``seen`` ``(C, B, F, 17)``."""
    valid = seen[:, :, 2:] & seen[:, :, 1:-1] & seen[:, :, :-2]
    return second_difference(coords), valid


def fit_to_noise(
    joints: torch.Tensor, obs: Observations, noise: torch.Tensor, fps: float, iterations: int = 2
) -> torch.Tensor:
    """Joints ``(B, N, F, 17, 3)`` moved to the most likely motion under keypoint ``noise`` ``(B,)`` (see the module).

    Gauss-Newton on the data and acceleration energies together, each joint's path one banded
    system over the frames; a step that raises the energy is not taken.
    """
    B, N, F = joints.shape[:3]
    if F < 3:
        return joints
    missing = ~torch.isfinite(joints).all(-1, keepdim=True)  # a track's padding frames: no joints
    joints = hold_nearest(joints, ~missing[..., 0])
    weight = acceleration_weight(noise, fps)[:, None].expand(B, N, 17)

    def total(x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        energy, grad, curvature = reprojection_terms(x, obs)
        smooth = (weight[:, :, None] * (second_difference(x) ** 2).sum(-1)).sum(dim=(-1, -2))
        return energy.sum(-1) + smooth, grad, curvature

    energy, grad, curvature = total(joints)
    eye = torch.eye(3, dtype=joints.dtype, device=joints.device)
    for _ in range(iterations):
        hessian = unpack_symmetric(curvature)  # (B, N, F, 17, 3, 3)
        damping = 1e-3 * hessian.diagonal(dim1=-2, dim2=-1).mean(dim=(-1, -2, -3)).clamp(min=1e-9)  # (B, N)
        normal = hessian + damping[..., None, None, None, None] * eye
        penalty_grad = _acceleration_gradient(joints, weight)  # (B, N, F, 17, 3), of the smoothing energy
        rhs = -(grad.movedim(0, -1) + penalty_grad)
        per_joint = (B, N * 17, F)  # every joint's path is one system
        step = solve_smoothed(
            normal.permute(0, 1, 3, 2, 4, 5).reshape(*per_joint, 3, 3),
            rhs.permute(0, 1, 3, 2, 4).reshape(*per_joint, 3),
            (2 * weight).reshape(B, N * 17),
        )
        step = step.reshape(B, N, 17, F, 3).permute(0, 1, 3, 2, 4)
        candidate = joints + step
        new_energy, new_grad, new_curvature = total(candidate)
        better = (new_energy < energy)[..., None, None, None]
        joints = torch.where(better, candidate, joints)
        energy = torch.where(better[..., 0, 0, 0], new_energy, energy)
        grad = torch.where(better[None, ..., 0], new_grad, grad)
        curvature = torch.where(better[None, ..., 0], new_curvature, curvature)
    return joints.masked_fill(missing, float("nan"))


def hold_nearest(joints: torch.Tensor, valid: torch.Tensor) -> torch.Tensor:
    """Joints ``(B, N, F, 17, 3)`` with every frame where ``valid`` ``(B, N, F, 17)`` is False taken from the nearest
    earlier valid frame (or, before the first, the first one); all-invalid paths become zeros."""
    frames = torch.arange(joints.shape[2], device=joints.device)[None, None, :, None]
    before = torch.where(valid, frames, -1).cummax(dim=2).values
    first = torch.where(valid, frames, joints.shape[2]).flip(2).cummin(dim=2).values.flip(2)
    source = torch.where(before >= 0, before, first).clamp(max=joints.shape[2] - 1)
    held = torch.gather(joints, 2, source[..., None].expand(*source.shape, 3))
    return torch.nan_to_num(held, nan=0.0, posinf=0.0, neginf=0.0)


def acceleration_weight(noise: torch.Tensor, fps: float) -> torch.Tensor:
    """``sigma^2 / a_j^2`` ``(B, 17)``: the weight of each joint's squared accelerations against the data energy."""
    typical = torch.tensor(TYPICAL_ACCELERATIONS, dtype=noise.dtype, device=noise.device) * (30.0 / fps) ** 2
    return (noise[:, None] / typical) ** 2


def posterior_shrink(curvature: torch.Tensor, weight: torch.Tensor) -> torch.Tensor:
    """Per window, frame and joint ``(B, F, 17)``: the variance of the smoothed fit over that of the frame's own
    least-squares fit, ``h [(h I + 2 w D^T D)^-1]_ff``, with h each joint's mean data curvature (one value per axis)
    from the fit's packed curvature ``(6, B, N, F, 17)`` (:func:`lifting.sampling.energy.reprojection_terms`).

    The noise spread of several cameras draws from the least-squares uncertainty; after the
    smoothing fit, which averages neighbouring frames, its draws are shrunk by this factor.
    """
    B, _, F = curvature.shape[1:4]
    if F < 3:  # nothing was smoothed
        return torch.ones(B, F, 17, dtype=curvature.dtype, device=curvature.device)
    h = (curvature[0] + curvature[3] + curvature[5]).nanmean(dim=(1, 2)).double() / 3  # (B, 17): mean, hyps, frames
    measured = h > 0  # a joint no camera sees in the window has no fit to shrink (and a singular system)
    h = torch.where(measured, h, torch.ones_like(h))
    penalty = acceleration_penalty(F, torch.float64, curvature.device)
    system = h[..., None, None] * torch.eye(F, dtype=torch.float64, device=curvature.device)
    system = system + 2 * weight.double()[..., None, None] * penalty  # (B, 17, F, F)
    variance = torch.linalg.inv(system).diagonal(dim1=-2, dim2=-1)  # (B, 17, F)
    shrink = torch.where(measured[..., None], (h[..., None] * variance).clamp(max=1.0), torch.ones_like(variance))
    return shrink.transpose(1, 2).to(curvature.dtype)


def _acceleration_gradient(joints: torch.Tensor, weight: torch.Tensor) -> torch.Tensor:
    """Gradient ``2 w D^T D x`` of ``sum_j w_j |D x_j|^2`` for joints ``(B, N, F, 17, 3)``, weights ``(B, N, 17)``."""
    scaled = 2 * weight[:, :, None, :, None] * second_difference(joints)  # (B, N, F-2, 17, 3)
    grad = torch.zeros_like(joints)
    grad[:, :, :-2] += scaled
    grad[:, :, 1:-1] -= 2 * scaled
    grad[:, :, 2:] += scaled
    return grad


def smooth_keypoints(obs: Observations, noise: torch.Tensor) -> Observations:
    """One camera: the keypoints' most likely paths ``(C, B, F, 17, 2)`` under their ``noise`` ``(B,)``.

    Per window, joint and coordinate, minimise ``sum_t c_t (k_t - y_t)^2 + (sigma^2 / a^2) |D k|^2``:
    sigma the noise (normalised image units, as :func:`keypoint_noise`), a the joint's own RMS
    acceleration in the track less what the noise explains. Guidance then fits these paths, and
    the depth stays the prior's. Returns observations with the smoothed undistorted coordinates.
    """
    C, B, F = obs.normalized.shape[:3]
    if F < 3:
        return obs
    focal = obs.cameras.K[:, 0, 0].reshape(-1, 1, 1, 1, 1)
    scale = obs.pixel_scale.reshape(-1, 1, 1, 1, 1) * focal  # normalised image units per undistorted unit
    coords = obs.normalized.double() * scale.double()  # (C, B, F, 17, 2), normalised image units
    weight = (obs.confidence > 0).double() * obs.confidence.double()  # (C, B, F, 17)
    second, seen = _seen_second_differences(coords, weight > 0)
    count = seen.sum(2).clamp(min=1)[..., None]  # (C, B, 17, 1)
    mean_square = (second.pow(2) * seen[..., None]).sum(2) / count  # (C, B, 17, 2)
    variance = noise.double()[None, :, None, None] ** 2
    motion = (mean_square - 6 * variance).clamp(min=variance)  # the track's own accelerations, at least the noise's
    ratio = variance / motion.clamp(min=1e-20)  # (C, B, 17, 2); exact straight paths: 0
    penalty = acceleration_penalty(F, torch.float64, coords.device)
    system = torch.diag_embed(weight.permute(0, 1, 3, 2)[..., None, :].expand(C, B, 17, 2, F))  # (C, B, 17, 2, F, F)
    system = system + ratio[..., None, None] * penalty + 1e-9 * torch.eye(F, dtype=torch.float64, device=coords.device)
    rhs = (weight[..., None] * coords).permute(0, 1, 3, 4, 2)[..., None]  # (C, B, 17, 2, F, 1)
    smoothed = torch.linalg.solve(system, rhs)[..., 0].permute(0, 1, 4, 2, 3) / scale.double()
    normalized = torch.where(obs.confidence[..., None] > 0, smoothed.to(obs.normalized.dtype), obs.normalized)
    return Observations(obs.cameras, obs.keypoints, normalized, obs.confidence)
