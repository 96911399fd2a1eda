"""Where several views see a person, the images correct the sampler's lasting offsets from what they measure.

The sampler follows the keypoints only as far as its few guided steps take it, and its noise fit smooths them
over time on purpose (docs/prior.md). What it leaves is of two kinds: the keypoints' jitter, which it should
leave, and slow offsets the images do not support (a wrist a centimetre off for a second). Only the second is
corrected here, before a person is made rigid. For the sampler's answer ``x0`` each joint seen by two views or
more has the point that minimises, together,

    sum over the views c seeing it of  conf_c |A_c (x - m)|^2   +   SAMPLER_WEIGHT |x - x0|^2,

``m`` the confidence-weighted triangulation of its keypoints (:func:`lifting.triangulation.triangulate`),
``A_c = I - d_c d_c^T`` the displacement across view ``c``'s ray ``d_c`` through ``m`` (for small moves, the
reprojection error in that view times the depth). The move there, smoothed over time so that only what lasts
remains (``SHIFT_SMOOTHNESS``: a change at about 1 Hz is halved, faster ones vanish), shifts every hypothesis
alike: their spread about the answer, which says what the keypoints' noise leaves uncertain
(:mod:`lifting.sampling.noise_spread`), stays as it was.

Following each frame's triangulation instead (the move unsmoothed, or a move per hypothesis) brought a four-view
lift nearer that triangulation but, on mocap seen through noisy keypoints, moved the answer away from the truth,
tripled its velocity error or collapsed its spread (docs/results.md). A triangulated point more than
``FARTHEST_M`` from the sampler's joint is not used: the views disagree with a prior that follows them
everywhere else (a keypoint on another person in one view). One view measures no point: nothing moves.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.finish.smoothing import present_spans, smooth_over_time
from platypose.lifting.triangulation import triangulate

SAMPLER_WEIGHT = 0.25  # of the sampler's joint, against each view's confidence (0..1) across its ray
FARTHEST_M = 0.25  # a measured point farther than this from the sampler's joint is not used
SHIFT_SMOOTHNESS = 625.0  # at 30 fps (scaled with the frame rate): halves a change at about 1 Hz


@dataclass(frozen=True)
class Measured:
    """What several views measure of one person: ``points`` ``(T, 17, 3)`` (NaN where fewer than two views see a
    joint) and ``forms`` ``(T, 17, 3, 3)``, the confidence-weighted sum of the views' across-ray projectors there."""

    points: np.ndarray
    forms: np.ndarray


def measure(keypoints: np.ndarray, cameras: Sequence[Camera]) -> Measured:
    """What the views measure of a person whose keypoints are ``(C, T, 17, 3)`` (pixels and confidence; 0 or NaN
    where a view does not see a joint) seen by ``cameras``."""
    confidence = np.nan_to_num(np.asarray(keypoints[..., 2], np.float64))  # (C, T, 17)
    points = triangulate(np.nan_to_num(keypoints[..., :2]), confidence, cameras)  # (T, 17, 3)
    centres = np.stack([cam.center for cam in cameras])
    rays = np.nan_to_num(points)[:, :, None, :] - centres  # (T, 17, C, 3)
    rays /= np.maximum(np.linalg.norm(rays, axis=-1, keepdims=True), 1e-9)
    across = np.eye(3) - rays[..., :, None] * rays[..., None, :]
    forms = np.einsum("ctj,tjcab->tjab", confidence, across)
    return Measured(points, forms)


def image_pull(joints: np.ndarray, measured: Measured) -> np.ndarray:
    """Per frame, the move ``(T, 17, 3)`` of joints ``(T, 17, 3)`` to the minimiser of the module's sum where
    ``measured`` has a point near them; zero elsewhere (and where a joint is absent, NaN)."""
    points = np.nan_to_num(measured.points)
    pulled = np.linalg.solve(
        measured.forms + SAMPLER_WEIGHT * np.eye(3),
        (np.einsum("tjab,tjb->tja", measured.forms, points) + SAMPLER_WEIGHT * np.nan_to_num(joints))[..., None],
    )[..., 0]
    with np.errstate(invalid="ignore"):
        near = np.linalg.norm(measured.points - joints, axis=-1) <= FARTHEST_M  # False where either is NaN
    return np.where(near[..., None], pulled - np.nan_to_num(joints), 0.0)


def steady_shift(answer: np.ndarray, measured: Measured, fps: float) -> np.ndarray:
    """The shift ``(T, 17, 3)`` the images ask of a person's sampled ``answer`` ``(T, 17, 3)`` (NaN where absent)
    and, alike, of each of their hypotheses: :func:`image_pull` smoothed over each run of present frames."""
    pull = image_pull(answer, measured)
    smoothness = SHIFT_SMOOTHNESS * (fps / 30.0) ** 4  # the same cut-off in Hz at any frame rate
    for span in present_spans(np.isfinite(answer).all(axis=(1, 2))):
        pull[span] = smooth_over_time(pull[span], smoothness)
    return pull
