"""Guidance energies: reprojection error over any number of cameras, and structural terms.

Reprojection residuals are measured in normalised image units: pixels times
``2 / width`` of that camera (the convention of Human3.6M's screen
normalisation, so the paper's energy scales keep their meaning), which makes
the guidance scale mean the same for every image size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from platypose.lifting.camera import CameraBatch, undistort_normalized
from platypose.lifting.sampling.linalg import SYMMETRIC_PAIRS
from platypose.lifting.settings import ROBUST_LOSSES
from platypose.lifting.skeleton import BONES, SYMMETRIC_BONES


@dataclass(frozen=True)
class Observations:
    """2D evidence for a batch of B windows seen by C cameras.

    ``keypoints`` (C, B, F, 17, 2) pixels, ``normalized`` the same undistorted to
    normalised camera coordinates, ``confidence`` (C, B, F, 17) >= 0 with 0 for
    missing keypoints (whose coordinates are zeroed).
    """

    cameras: CameraBatch
    keypoints: torch.Tensor
    normalized: torch.Tensor
    confidence: torch.Tensor

    @staticmethod
    def from_arrays(
        cameras: CameraBatch, keypoints: np.ndarray, confidence: np.ndarray, dtype: torch.dtype = torch.float32
    ) -> Observations:
        """Build from numpy arrays, zeroing the confidence and coordinates of non-finite keypoints."""
        keypoints = np.asarray(keypoints, dtype=np.float64)
        confidence = np.asarray(confidence, dtype=np.float64)
        finite = np.isfinite(keypoints).all(axis=-1) & np.isfinite(confidence)
        conf = np.where(finite, np.clip(confidence, 0.0, None), 0.0)
        kp = np.where(finite[..., None], keypoints, 0.0)
        K = cameras.K.detach().cpu().numpy().astype(np.float64)
        dist = cameras.dist.detach().cpu().numpy().astype(np.float64)
        normalized = np.stack([undistort_normalized(kp[c], K[c], dist[c]) for c in range(len(K))])
        normalized = np.where(finite[..., None], normalized, 0.0)
        device = cameras.K.device

        def tensor(values: np.ndarray) -> torch.Tensor:
            return torch.as_tensor(values, dtype=dtype, device=device)

        return Observations(cameras, tensor(kp), tensor(normalized), tensor(conf))

    @property
    def pixel_scale(self) -> torch.Tensor:
        """Normalised units per pixel of each camera, ``2 / width``, ``(C,)``."""
        return 2.0 / self.cameras.size[:, 1]


def robust_penalty(squared: torch.Tensor, loss: str, scale: float) -> torch.Tensor:
    """Penalty of squared residuals: ``l2`` is the identity, ``geman-mcclure`` is ``s * c^2 / (s + c^2)``."""
    if loss == "l2":
        return squared
    if loss == "geman-mcclure":
        c2 = scale * scale
        return squared * c2 / (squared + c2)
    raise ValueError(f"unknown robust loss {loss!r}; choose one of {', '.join(ROBUST_LOSSES)}")


def reprojection_energy(joints: torch.Tensor, obs: Observations, loss: str = "l2", scale: float = 0.05) -> torch.Tensor:
    """Per-frame energy ``(B, N, F)`` of world joints ``(B, N, F, 17, 3)`` against the observations.

    Sum over cameras and joints of confidence times the robust penalty of the
    squared residual in normalised image units.
    """
    pixels = obs.cameras.project(joints)  # (C, B, N, F, 17, 2)
    target = obs.keypoints.unsqueeze(2)
    scale_c = obs.pixel_scale.reshape(-1, 1, 1, 1, 1)
    squared = ((pixels - target) ** 2).sum(-1) * scale_c**2
    weighted = obs.confidence.unsqueeze(2) * robust_penalty(squared, loss, scale)
    return weighted.sum(dim=(0, -1))


def robust_slope(squared: torch.Tensor, loss: str, scale: float) -> torch.Tensor:
    """Derivative of :func:`robust_penalty` with respect to the squared residual (a 0-d one for ``l2``)."""
    if loss == "l2":
        return squared.new_ones(())  # a scalar: broadcasts without a full-size array of ones
    c2 = scale * scale
    return (c2 / (squared + c2)) ** 2


@dataclass(frozen=True)
class ViewResiduals:
    """One camera's guidance quantities, each ``(B, N, F, 17)``: ratios ``u``, ``v`` (camera-frame x/z, y/z),
    ``inverse_depth``, residuals in normalised image units, and ``weight`` = 2 conf * robust slope; ``gains``
    (normalised image units per unit of u and of v); ``energy`` ``(B, N, F)``."""

    u: torch.Tensor
    v: torch.Tensor
    inverse_depth: torch.Tensor
    residual_u: torch.Tensor
    residual_v: torch.Tensor
    weight: torch.Tensor
    gains: tuple[float, float]
    energy: torch.Tensor


def view_residuals(
    joints: torch.Tensor, obs: Observations, loss: str, scale: float, in_camera_frame: bool = False
) -> list[ViewResiduals]:
    """Residuals of world joints ``(B, N, F, 17, 3)`` in every camera (one matrix product moves them all), or of
    joints already in the frame of the one camera (``in_camera_frame``)."""
    cams = obs.cameras
    C = len(cams)
    shape = joints.shape[:-1]  # (B, N, F, 17)
    if in_camera_frame:
        camera_frame = joints.reshape(-1, 3).T  # a view for component-first storage
    else:
        camera_frame = torch.addmm(cams.t.reshape(3 * C, 1), cams.R.reshape(3 * C, 3), joints.reshape(-1, 3).T)
    camera_frame = camera_frame.reshape(C, 3, *shape)
    gains = (torch.stack([cams.K[:, 0, 0], cams.K[:, 1, 1]], -1) * obs.pixel_scale[:, None]).tolist()
    views = []
    for c in range(C):
        x, y, depth = camera_frame[c]
        inverse_depth = depth.clamp(min=1e-3).reciprocal_()
        u, v = x * inverse_depth, y * inverse_depth
        target = obs.normalized[c].unsqueeze(1)  # (B, 1, F, 17, 2)
        gain_u, gain_v = gains[c]
        residual_u = (u - target[..., 0]).mul_(gain_u)
        residual_v = (v - target[..., 1]).mul_(gain_v)
        squared = torch.mul(residual_u, residual_u).addcmul_(residual_v, residual_v)
        conf = obs.confidence[c].unsqueeze(1)  # (B, 1, F, 17)
        energy = (conf * robust_penalty(squared, loss, scale)).sum(-1)
        weight = 2 * conf * robust_slope(squared, loss, scale)
        views.append(ViewResiduals(u, v, inverse_depth, residual_u, residual_v, weight, (gain_u, gain_v), energy))
    return views


def reprojection_terms(
    joints: torch.Tensor, obs: Observations, loss: str = "l2", scale: float = 0.05, in_camera_frame: bool = False
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Energy ``(B, N, F)``, gradient ``(3, B, N, F, 17)`` and packed Gauss-Newton curvature ``(6, B, N, F, 17)``.

    Analytic and fused, for guidance: residuals are measured between undistorted
    normalised coordinates and scaled by the focal length into pixels (then into
    normalised image units), which equals :func:`reprojection_energy` up to the
    lens distortion's local stretch. Gradient and curvature are component-first
    (x, y, z; the curvature's six entries in ``SYMMETRIC_PAIRS`` order) so that
    every operation runs on contiguous per-component arrays. They are in world
    axes; with ``in_camera_frame`` (one camera only) the joints are given in that
    camera's frame (``R X + t``) and the terms come in its axes, where they are much
    cheaper.
    """
    views = view_residuals(joints, obs, loss, scale, in_camera_frame)
    if in_camera_frame:
        if len(views) != 1:
            raise ValueError(f"camera-frame terms need exactly one camera, got {len(views)}")
        return _camera_frame_terms(views[0])
    energy = sum(view.energy for view in views)
    grad = views[0].u.new_zeros((3, *views[0].u.shape))
    curvature = views[0].u.new_zeros((len(SYMMETRIC_PAIRS), *views[0].u.shape))
    for view, R in zip(views, obs.cameras.R.tolist()):
        (gain_u, gain_v), inverse_depth, weight = view.gains, view.inverse_depth, view.weight
        # Jacobian rows: gain / z * (R_row - ratio * R_z), for u (row 0) and v (row 1)
        rows_u = [(view.u * -R[2][k]).add_(R[0][k]) for k in range(3)]
        rows_v = [(view.v * -R[2][k]).add_(R[1][k]) for k in range(3)]
        curv_u = inverse_depth * inverse_depth * weight
        curv_v = curv_u * (gain_v * gain_v)
        curv_u.mul_(gain_u * gain_u)
        slope_u = (inverse_depth * weight).mul_(view.residual_u).mul_(gain_u)
        slope_v = (inverse_depth * weight).mul_(view.residual_v).mul_(gain_v)
        for k in range(3):
            grad[k].addcmul_(slope_u, rows_u[k]).addcmul_(slope_v, rows_v[k])
        weighted_u = [curv_u * r for r in rows_u]
        weighted_v = [curv_v * r for r in rows_v]
        for entry, (k, m) in zip(curvature, SYMMETRIC_PAIRS):
            entry.addcmul_(weighted_u[k], rows_u[m]).addcmul_(weighted_v[k], rows_v[m])
    return energy, grad, curvature


def _camera_frame_terms(view: ViewResiduals) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """One camera's gradient and curvature in its own axes, where the Jacobian rows are (1, 0, -u) and (0, 1, -v)."""
    (gain_u, gain_v), u, v = view.gains, view.u, view.v
    scaled = view.weight * view.inverse_depth
    grad = u.new_empty((3, *u.shape))  # written in place: no stacking copies
    slope_u = torch.mul(scaled, view.residual_u, out=grad[0]).mul_(gain_u)
    slope_v = torch.mul(scaled, view.residual_v, out=grad[1]).mul_(gain_v)
    torch.mul(slope_u, u, out=grad[2]).addcmul_(slope_v, v).neg_()
    scaled.mul_(view.inverse_depth)
    curvature = u.new_empty((len(SYMMETRIC_PAIRS), *u.shape))
    xx, xy, xz, yy, yz, zz = curvature
    torch.mul(scaled, gain_u * gain_u, out=xx)
    torch.mul(scaled, gain_v * gain_v, out=yy)
    xy.zero_()
    torch.mul(xx, u, out=xz).neg_()
    torch.mul(yy, v, out=yz).neg_()
    torch.mul(xz, u, out=zz).addcmul_(yz, v).neg_()
    return view.energy, grad, curvature


def bone_lengths_torch(joints: torch.Tensor) -> torch.Tensor:
    """Bone lengths ``(..., 17, 3) -> (..., 16)`` in ``BONES`` order.

    Each joint but the pelvis (0) is the child of one bone, in joint order, so the children are a
    slice and only the parents are gathered (a third of the time of two list-indexed gathers).
    """
    parents = torch.tensor([parent for _, parent in BONES], device=joints.device)
    return torch.linalg.vector_norm(joints[..., 1:, :] - joints.index_select(-2, parents), dim=-1)


def bone_constancy_energy(joints: torch.Tensor) -> torch.Tensor:
    """Per-frame squared deviation of bone lengths from their window mean, ``(B, N, F, 17, 3) -> (B, N, F)``, m^2."""
    lengths = bone_lengths_torch(joints)
    return ((lengths - lengths.mean(dim=-2, keepdim=True)) ** 2).sum(-1)


def symmetry_energy(joints: torch.Tensor) -> torch.Tensor:
    """Per-frame squared left/right bone-length difference, ``(B, N, F, 17, 3) -> (B, N, F)``, m^2."""
    lengths = bone_lengths_torch(joints)
    left = lengths[..., [a for a, _ in SYMMETRIC_BONES]]
    right = lengths[..., [b for _, b in SYMMETRIC_BONES]]
    return ((left - right) ** 2).sum(-1)
