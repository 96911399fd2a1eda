"""Time offsets of unsynchronised views, estimated from the 2D keypoints' motion.

Two steps, each on arrays:

1. **Coarse, by motion.** Per view, a one-dimensional signal: the confidence-weighted mean vertical
   image speed of the joints, in person heights per second (vertical motion looks alike from every
   upright camera; horizontal motion depends on where the camera stands). The signals are
   resampled on a common time grid at the reference view's frame rate, using each frame's own
   time, and each view's signal is cross-correlated (normalised, over the overlap) with the
   reference's. The lag of the highest correlation is the motion estimate.
2. **Fine, by geometry.** Each view's offset is moved by whole frames, then tenths of a frame, to
   where all views triangulated together (keypoints interpolated at the reference frames' times)
   reproject best, never more than ``REFINE_FRAMES`` from the motion estimate: wrongly timed views
   of a moving person disagree on where the joints are, but a view's calibration error can also
   be hidden by a wrong timing, so the motion estimate bounds it.

The offsets follow ``Camera.time_offset_s``: a view that started recording 0.5 s after the
reference gets +0.5 (its frame times plus the offset are on the reference's clock).
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.triangulation import reprojection_errors, triangulate


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """NumPy's floating-point and all-NaN warnings off: frames where a view sees nobody are NaN by design."""
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        yield


MIN_CONFIDENCE = 0.3  # joints below this confidence are not used
SMOOTH_S = 0.05  # moving-average width of the motion signal
MIN_OVERLAP = 0.5  # a lag must overlap this fraction of the shorter signal
MAX_OFFSET_S = 10.0  # default search range, also capped at half the shorter view
DISTINCT_S = 0.15  # the runner-up peak is sought this far from the best lag
REFINE_FRAMES = 2  # geometric refinement stays within this many frames of the motion estimate ...
REFINE_STEP = 0.1  # ... then steps of this many frames within one frame of the best
REFINE_PASSES = 2  # every view is refined this many times, the others held at their latest offsets
MAX_REFINE_FRAMES = 300  # reference frames used by the refinement (evenly spread)
MIN_MOTION = 0.1  # median motion signal (person heights per second) below which a view is taken as still


@dataclass(frozen=True)
class SyncEstimate:
    """Per view (C,): ``offsets_s`` to add to its frame times (reference 0), the coarse correlation peak,
    ``confidence`` in [0, 1] (how far that peak stands above the runner-up lag; 1 for the reference);
    the median reprojection error of all views with no offsets and with these (pixels), the
    reference frame rate, and ``at_limit`` (C,): the geometric refinement stopped at the edge of its
    window around the motion estimate (the view's reprojection wants more: often a calibration error);
    ``motion`` (C,): the median motion signal (person heights per second); a view below ``MIN_MOTION`` (or any
    view when the reference is) has confidence 0 and no coarse lag, as its motion says nothing about time.
    """

    offsets_s: np.ndarray
    correlation: np.ndarray
    confidence: np.ndarray
    error_before_px: float
    error_after_px: float
    rate: float
    at_limit: np.ndarray
    motion: np.ndarray

    @property
    def offsets_frames(self) -> np.ndarray:
        """The offsets in reference frames."""
        return self.offsets_s * self.rate


def main_person(keypoints: np.ndarray) -> np.ndarray:
    """Per frame, the person (T, J, 3) with the highest summed confidence, from ``keypoints`` (T, P, J, 3)."""
    keypoints = np.asarray(keypoints, dtype=np.float64)
    if keypoints.shape[1] == 0:
        return np.zeros((keypoints.shape[0], *keypoints.shape[2:]))
    best = keypoints[..., 2].sum(-1).argmax(1)
    return keypoints[np.arange(len(keypoints)), best]


def motion_signal(keypoints: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Vertical image speed (T,) of one person (T, J, 3), in person heights per second; NaN where unseen."""
    y = np.where(keypoints[..., 2] >= MIN_CONFIDENCE, keypoints[..., 1], np.nan)
    with _quiet():
        height = np.nanmedian(np.nanmax(y, axis=1) - np.nanmin(y, axis=1))
    if not np.isfinite(height) or height <= 0:
        return np.full(len(times), np.nan)
    velocity = np.gradient(y, times, axis=0) if len(times) > 1 else np.zeros_like(y)
    weight = np.where(np.isfinite(velocity), keypoints[..., 2], 0.0)
    with _quiet():
        signal = np.nansum(np.abs(np.nan_to_num(velocity)) * weight, axis=1) / weight.sum(1)
    return signal / height


def _resample(times: np.ndarray, signal: np.ndarray, rate: float) -> np.ndarray:
    """``signal`` on a grid from ``times[0]`` at ``rate``, smoothed; NaN where the view has no frame near."""
    grid = times[0] + np.arange(int(np.floor((times[-1] - times[0]) * rate)) + 1) / rate
    valid = np.isfinite(signal)
    if valid.sum() < 2:
        return np.full(len(grid), np.nan)
    out = np.interp(grid, times[valid], signal[valid])
    gap = np.abs(grid - times[valid][np.clip(np.searchsorted(times[valid], grid), 0, valid.sum() - 1)])
    out[gap > 2.0 / rate] = np.nan
    width = max(int(round(SMOOTH_S * rate)), 1)
    if width > 1:
        kernel = np.ones(width) / width
        filled = np.nan_to_num(out)
        counts = np.convolve(np.isfinite(out).astype(float), kernel, mode="same")
        with _quiet():
            out = np.where(np.isfinite(out), np.convolve(filled, kernel, mode="same") / counts, np.nan)
    return out


def lag_correlation(reference: np.ndarray, signal: np.ndarray, max_lag: int) -> tuple[np.ndarray, np.ndarray]:
    """Normalised correlation of ``reference[k + lag]`` with ``signal[k]`` for every lag in [-max_lag, max_lag].

    Returns the lags (L,) and correlations (L,), NaN where the overlap is too short.
    """
    lags = np.arange(-max_lag, max_lag + 1)
    shortest = min(np.isfinite(reference).sum(), np.isfinite(signal).sum())
    out = np.full(len(lags), np.nan)
    for i, lag in enumerate(lags):
        k = np.arange(max(0, -lag), min(len(signal), len(reference) - lag))
        a, b = reference[k + lag] if len(k) else k, signal[k] if len(k) else k
        ok = np.isfinite(a) & np.isfinite(b)
        if ok.sum() < max(MIN_OVERLAP * shortest, 3):
            continue
        a, b = a[ok] - a[ok].mean(), b[ok] - b[ok].mean()
        denominator = np.sqrt((a * a).sum() * (b * b).sum())
        out[i] = (a * b).sum() / denominator if denominator > 0 else np.nan
    return lags, out


def _peak(lags: np.ndarray, corr: np.ndarray, distinct: int) -> tuple[int, float, float]:
    """Best lag, its correlation and the confidence ``(peak - runner_up) / (1 - runner_up)`` in [0, 1]."""
    if not np.isfinite(corr).any():
        return 0, float("nan"), 0.0
    best = int(np.nanargmax(corr))
    far = np.abs(lags - lags[best]) > distinct
    runner_up = float(np.nanmax(corr[far])) if np.isfinite(corr[far]).any() else -1.0
    peak = float(corr[best])
    confidence = (peak - runner_up) / (1.0 - runner_up) if runner_up < 1.0 else 0.0
    return int(lags[best]), peak, float(np.clip(confidence, 0.0, 1.0))


def sample_at(keypoints: np.ndarray, times: np.ndarray, at: np.ndarray) -> np.ndarray:
    """One person's keypoints (T, J, 3) linearly interpolated at times ``at`` (N,); confidence 0 outside or across gaps."""
    position = np.interp(at, times, np.arange(len(times)), left=-1.0, right=-1.0)
    inside = (position >= 0) & (at >= times[0]) & (at <= times[-1])
    lower = np.clip(np.floor(position).astype(int), 0, len(times) - 1)
    upper = np.clip(lower + 1, 0, len(times) - 1)
    w = (position - lower)[:, None, None]
    a, b = keypoints[lower], keypoints[upper]
    out = (1 - w) * a + w * b
    both = (a[..., 2] > 0) & (b[..., 2] > 0) & inside[:, None]
    out[..., 2] = np.where(both, np.minimum(a[..., 2], b[..., 2]), 0.0)
    return out


def views_error(
    views: Sequence[np.ndarray],
    times: Sequence[np.ndarray],
    cameras: Sequence[Camera],
    offsets_s: np.ndarray,
    at: np.ndarray,
) -> float:
    """Median reprojection error (px) of all views triangulated together at reference times ``at``, each view shifted by its offset."""
    moved = np.stack([sample_at(v, t + o, at) for v, t, o in zip(views, times, offsets_s)])
    weights = np.where(moved[..., 2] >= MIN_CONFIDENCE, moved[..., 2], 0.0)
    points = triangulate(moved[..., :2], weights, cameras)
    errors = reprojection_errors(points, moved[..., :2], cameras)
    seen = np.isfinite(points).all(-1)[None] & (weights > 0)
    return float(np.median(errors[seen])) if seen.any() else float("nan")


def offsets_error(
    views: Sequence[np.ndarray], frame_times: Sequence[np.ndarray], cameras: Sequence[Camera], offsets_s
) -> float:
    """Median reprojection error (px) of one person's ``views`` triangulated together, each view's ``frame_times``
    shifted by its offset in ``offsets_s``, at (up to ``MAX_REFINE_FRAMES`` of) the first view's frame times."""
    times = [np.asarray(t, dtype=np.float64) for t in frame_times]
    at = times[0][:: max(len(times[0]) // MAX_REFINE_FRAMES, 1)]
    views = [np.asarray(v, dtype=np.float64) for v in views]
    return views_error(views, times, cameras, np.asarray(offsets_s, dtype=np.float64), at)


def _refine(
    views: Sequence[np.ndarray],
    times: Sequence[np.ndarray],
    cameras: Sequence[Camera],
    offsets: np.ndarray,
    rate: float,
) -> np.ndarray:
    """Offsets moved, one view at a time, to the sub-frame value with the smallest joint reprojection error.

    Whole frames, then tenths of a frame within one frame of the best; never farther than
    ``REFINE_FRAMES`` from the motion estimate (``offsets``), so that a view's calibration error
    cannot pull its timing far from what the motion says.
    """
    at = times[0][:: max(len(times[0]) // MAX_REFINE_FRAMES, 1)]
    coarse, offsets = offsets, offsets.copy()
    for c in [*range(1, len(views))] * REFINE_PASSES:
        for steps in (np.arange(-REFINE_FRAMES, REFINE_FRAMES + 1), np.arange(-1.0, 1.0 + 1e-9, REFINE_STEP)):
            trials = offsets[None] + np.outer(steps / rate, np.eye(len(views))[c])
            trials = trials[np.abs(trials[:, c] - coarse[c]) <= (REFINE_FRAMES + 1e-6) / rate]
            errors = np.array([views_error(views, times, cameras, trial, at) for trial in trials])
            if np.isfinite(errors).any():
                offsets = trials[int(np.nanargmin(errors))]
    return offsets


def estimate_offsets(
    views: Sequence[np.ndarray],
    frame_times: Sequence[np.ndarray],
    cameras: Sequence[Camera],
    max_offset_s: float | None = None,
) -> SyncEstimate:
    """Offsets (s) putting every view on the first view's clock, from one person's keypoints per view.

    ``views[c]`` (T_c, J, 3) pixels and confidence, ``frame_times[c]`` (T_c,) each frame's own time
    in seconds (variable frame rate allowed), ``cameras[c]`` calibrated in one world.
    ``max_offset_s`` bounds the search (default: half the shorter view, at most 10 s).
    """
    times = [np.asarray(t, dtype=np.float64) for t in frame_times]
    views = [np.asarray(v, dtype=np.float64) for v in views]
    rate = 1.0 / float(np.median(np.diff(times[0]))) if len(times[0]) > 1 else 1.0
    raw = [motion_signal(v, t) for v, t in zip(views, times)]
    with _quiet():
        motion = np.array([np.nanmedian(r) if np.isfinite(r).any() else 0.0 for r in raw])
    signals = [_resample(t, r, rate) for r, t in zip(raw, times)]
    shortest = min(t[-1] - t[0] for t in times)
    bound = min(MAX_OFFSET_S, 0.5 * shortest) if max_offset_s is None else max_offset_s
    max_lag = max(int(round(bound * rate)), 1)
    C = len(views)
    coarse, correlation, confidence = np.zeros(C), np.ones(C), np.ones(C)
    for c in range(1, C):
        lags, corr = lag_correlation(signals[0], signals[c], max_lag)
        lag, correlation[c], confidence[c] = _peak(lags, corr, int(round(DISTINCT_S * rate)))
        if min(motion[0], motion[c]) < MIN_MOTION:  # a still view's signal is noise: no lag, no confidence
            lag, confidence[c] = 0, 0.0
        # reference[k + lag] matches signal[k]: grid time t_c0 + k / rate is reference time t_00 + (k + lag) / rate
        coarse[c] = times[0][0] - times[c][0] + lag / rate
    offsets = _refine(views, times, cameras, coarse, rate)
    before = offsets_error(views, times, cameras, np.zeros(C))
    after = offsets_error(views, times, cameras, offsets)
    at_limit = np.abs(offsets - coarse) * rate >= REFINE_FRAMES - 0.5 * REFINE_STEP
    return SyncEstimate(offsets, correlation, confidence, before, after, rate, at_limit, motion)


def with_offsets(cameras: Sequence[Camera], offsets_s: Sequence[float]) -> list[Camera]:
    """The cameras with ``time_offset_s`` set to ``offsets_s`` (one per camera)."""
    return [replace(c, time_offset_s=float(o)) for c, o in zip(cameras, offsets_s)]
