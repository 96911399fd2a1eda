"""Resampling motion and keypoint tracks between frame rates (linear interpolation in time)."""

from __future__ import annotations

import numpy as np


def resample_times(num_frames: int, fps: float, new_fps: float) -> np.ndarray:
    """Times (s) of frames at ``new_fps`` covering a clip of ``num_frames`` at ``fps``, ``(T',)``."""
    duration = (num_frames - 1) / fps
    count = int(np.floor(duration * new_fps + 1e-9)) + 1
    return np.arange(count) / new_fps


def interpolate(values: np.ndarray, times: np.ndarray, new_times: np.ndarray) -> np.ndarray:
    """Linearly interpolate ``values`` (T, ...) sampled at ``times`` (T,) onto ``new_times`` (T',) -> (T', ...).

    Times outside the sampled range take the nearest end value.
    """
    if len(times) == 1:
        return np.repeat(values[:1], len(new_times), axis=0)
    idx, w = interpolation_weights(times, new_times)
    return blend_samples(values, idx, w)


def interpolation_weights(times: np.ndarray, new_times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per new time (T',): the sample before it in ``times`` (T >= 2,), ``idx``, and the weight ``w`` of ``idx + 1``.

    Times outside the sampled range take the nearest end value (``w`` clipped to 0..1).
    """
    times = np.asarray(times, dtype=np.float64)
    idx = np.clip(np.searchsorted(times, new_times, side="right") - 1, 0, len(times) - 2)
    span = times[idx + 1] - times[idx]
    w = np.clip((new_times - times[idx]) / np.where(span > 0, span, 1.0), 0.0, 1.0)
    return idx, w


def blend_samples(values: np.ndarray, idx: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``(1 - w) * values[idx] + w * values[idx + 1]`` along the first axis, ``(len(idx), ...)``.

    A sample of weight 0 takes no part: at a sample's own time a NaN or inf neighbour neither spreads nor warns.
    """
    w = w.reshape(-1, *([1] * (values.ndim - 1)))
    before = np.where(w < 1, values[idx], 0.0)
    after = np.where(w > 0, values[idx + 1], 0.0)
    return (1 - w) * before + w * after


def resample(values: np.ndarray, fps: float, new_fps: float) -> np.ndarray:
    """Resample a uniformly sampled sequence ``(T, ...)`` from ``fps`` to ``new_fps``."""
    if np.isclose(fps, new_fps):
        return values.copy()
    times = np.arange(len(values)) / fps
    return interpolate(values, times, resample_times(len(values), fps, new_fps))


def resample_keypoints(keypoints: np.ndarray, times: np.ndarray, new_times: np.ndarray) -> np.ndarray:
    """Keypoints ``(T, ..., 3)`` (x, y, confidence; NaN or confidence 0 = missing) onto ``new_times``.

    A resampled keypoint is missing unless both neighbouring samples are present.
    """
    if len(times) == 1:  # every new time takes the one sample
        zeros = np.zeros(len(new_times), dtype=np.intp)
        return resample_keypoints_at(np.concatenate([keypoints, keypoints]), zeros, zeros.astype(np.float64))
    return resample_keypoints_at(keypoints, *interpolation_weights(times, new_times))


def resample_keypoints_at(keypoints: np.ndarray, idx: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Keypoints ``(T, ..., 3)`` at samples ``idx`` (T',) blended with ``idx + 1`` by ``w`` (T',): ``(T', ..., 3)``."""
    present = (np.isfinite(keypoints).all(-1) & (keypoints[..., 2] > 0)).astype(np.float64)
    filled = np.where(present[..., None] > 0, keypoints, 0.0)
    values = blend_samples(filled, idx, w)
    valid = blend_samples(present, idx, w) > 1 - 1e-9
    values[..., 2] = np.where(valid, values[..., 2], 0.0)
    values[..., :2] = np.where(valid[..., None], values[..., :2], np.nan)
    return values
