"""Lifting whole tracks: resample to the prior's rate, sample windows in batches, stitch, resample back.

Input is 2D keypoints of P persons seen by C calibrated cameras on one clock;
output is N hypotheses per person at the input's frame times, each one
continuous motion across windows (see :mod:`lifting.windows`). Each window's
persons and hypotheses go through the network as one batch.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from lifting.camera import Camera
from lifting.prior import PriorBundle
from lifting.sampler import Anchor, SamplerConfig, cameras_and_rays, sample
from lifting.timebase import interpolate
from lifting.windows import WindowPlan, continuation_anchor, cut, plan_windows, stitch


@dataclass(frozen=True)
class WindowSettings:
    """Window length and overlap (prior frames) and the weight of the overlap anchors."""

    window: int = 64
    overlap: int = 16
    anchor_weight: float = 100.0


@dataclass(frozen=True)
class LiftOutput:
    """``hypotheses`` (P, N, T, 17, 3) world metres and per-frame reprojection ``energy`` (P, N, T)."""

    hypotheses: np.ndarray
    energy: np.ndarray


def prior_clock(frame_times: np.ndarray, fps: float) -> np.ndarray:
    """Times at the prior's rate spanning ``frame_times``, ``(T',)``."""
    start, end = float(frame_times[0]), float(frame_times[-1])
    return start + np.arange(int(np.floor((end - start) * fps + 1e-6)) + 1) / fps


def resample_keypoints(keypoints: np.ndarray, times: np.ndarray, new_times: np.ndarray) -> np.ndarray:
    """Keypoints ``(T, ..., 3)`` (x, y, confidence; NaN or confidence 0 = missing) onto ``new_times``.

    A resampled keypoint is missing unless both neighbouring samples are present.
    """
    present = (np.isfinite(keypoints).all(-1) & (keypoints[..., 2] > 0)).astype(np.float64)
    filled = np.where(present[..., None] > 0, keypoints, 0.0)
    values = interpolate(filled, times, new_times)
    valid = interpolate(present, times, new_times) > 1 - 1e-9
    values[..., 2] = np.where(valid, values[..., 2], 0.0)
    values[..., :2] = np.where(valid[..., None], values[..., :2], np.nan)
    return values


def lift_tracks(
    prior: PriorBundle,
    cameras: Sequence[Camera],
    keypoints: np.ndarray,
    frame_times: np.ndarray,
    config: SamplerConfig,
    settings: WindowSettings = WindowSettings(),
    root_trajectory: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> LiftOutput:
    """Lift P persons' keypoints ``(C, T, P, 17, 3)`` seen by ``cameras`` at ``frame_times`` ``(T,)``.

    ``root_trajectory`` (P, T, 3), if known, fixes each person's pelvis path.
    ``progress(done, total)`` counts windows.
    """
    C, T, P = keypoints.shape[:3]
    clock = prior_clock(frame_times, prior.fps)
    resampled = np.moveaxis(resample_keypoints(np.moveaxis(keypoints, 1, 0), frame_times, clock), 0, 1)  # (C, T', P, 17, 3)
    length = min(settings.window, prior.config.max_frames)
    plan = plan_windows(len(clock), length, min(settings.overlap, length // 2))
    per_window = cut(np.moveaxis(resampled, 2, 1), plan, axis=2)  # (W, C, P, F, 17, 3)
    roots = None
    if root_trajectory is not None:
        roots = cut(interpolate(np.moveaxis(root_trajectory, 1, 0), frame_times, clock), plan, axis=0)  # (W, F, P, 3)
        roots = np.moveaxis(roots, 2, 1)  # (W, P, F, 3)
    runner = _WindowRunner(prior, list(cameras), per_window, roots, config, settings, plan, progress)
    joints = np.zeros((plan.count, P, config.samples, plan.length, 17, 3), dtype=np.float32)
    energy = np.zeros((plan.count, P, config.samples, plan.length), dtype=np.float32)
    for w in range(plan.count):
        anchor = continuation_anchor(joints[w - 1], plan) if w > 0 else None
        joints[w], energy[w] = runner.run(w, anchor)
    stitched = stitch(np.moveaxis(joints, 3, 1), plan)  # (T', P, N, 17, 3)
    stitched_energy = stitch(np.moveaxis(energy, 3, 1), plan)  # (T', P, N)
    hypotheses = interpolate(stitched, clock, frame_times)  # (T, P, N, 17, 3)
    frame_energy = interpolate(stitched_energy, clock, frame_times)
    return LiftOutput(
        hypotheses=np.moveaxis(hypotheses, 0, 2).astype(np.float32),
        energy=np.moveaxis(frame_energy, 0, 2).astype(np.float32),
    )


class _WindowRunner:
    """Samples one window of all persons at a time (persons and hypotheses in one batch)."""

    def __init__(self, prior, cameras, per_window, roots, config, settings, plan: WindowPlan, progress) -> None:
        self.prior, self.cameras, self.per_window, self.roots = prior, cameras, per_window, roots
        self.config, self.settings, self.plan, self.progress = config, settings, plan, progress

    def run(self, w: int, anchor: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
        """Joints (P, N, F, 17, 3) and energy (P, N, F) of window ``w``; ``anchor`` = joints (P, N, F, 17, 3), mask (F,)."""
        kp = self.per_window[w]  # (C, P, F, 17, 3)
        P, F = kp.shape[1:3]
        obs, rays = cameras_and_rays(self.cameras, kp[..., :2], kp[..., 2])
        dtype = obs.keypoints.dtype
        root = torch.as_tensor(self.roots[w], dtype=dtype) if self.roots is not None else None
        held = None
        if anchor is not None:
            mask = torch.as_tensor(np.repeat(anchor[1][None], P, axis=0), dtype=dtype)
            held = Anchor(torch.as_tensor(anchor[0], dtype=dtype), mask, self.settings.anchor_weight)
        result = sample(self.prior, obs, None if root is not None else rays, self.config, F, root, held)
        if self.progress is not None:
            self.progress(w + 1, self.plan.count)
        return result.joints, result.energy
