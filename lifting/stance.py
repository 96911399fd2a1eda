"""Which ankle stands: the one definition the floor's estimate, the sampler's grounding, finishing and the checks use.

An ankle stands in a frame when it is the lower of the two (:func:`lower_ankles`, along the floor's up, world z
without a floor: :func:`ankle_heights`) and holds still there. How still is each caller's threshold, named where it
is used: slower than ``STANCE_SPEED`` (the floor's estimate, :func:`platypose.lifting.floor.stance_points`; the
sampler's grounding, :mod:`platypose.lifting.sampling.grounding`, the same rule on tensors), or within a band of its
standing height (:func:`standing_heights`: a low order statistic of the lower ankle's height about that time, so a
roof or a step stands too): ``STANCE_BAND`` for ``MIN_STANCE`` on end in the checks (:func:`stance_ankles`, which the
planted feet of :mod:`platypose.lifting.finish.stance_legs` hold too), ``STANDING_BAND`` in
:mod:`platypose.lifting.finish.steady_depth`.
"""

from __future__ import annotations

import numpy as np

ANKLES = (3, 6)  # right and left ankle (lifting.skeleton order)
ANKLE_HEIGHT = 0.1  # metres: an ankle keypoint above the floor, foot flat (bundled mocap 0.07-0.11, shoes add more)
STANCE_SPEED = 1.5  # m/s: a lower ankle slower than this stands (one view's depth jitter and sliding included)
STANCE_BAND = 0.05  # metres above a hypothesis's standing height
MIN_STANCE = 0.1  # seconds: an ankle in the band for less time is passing through it (running contact: 0.2-0.3 s)
SUPPORT_WINDOW = 1.0  # seconds either side of a frame over which its standing height is taken
STANDING_QUANTILE = 10  # percentile of the lower ankle's height there: its standing height (a jump's flight is higher)
HYPOTHESES_AT_ONCE = 64  # hypotheses whose standing heights are found at a time
WORLD_UP = (0.0, 0.0, 1.0)  # heights along world z when no floor is known


def ankle_heights(joints: np.ndarray, floor=None) -> np.ndarray:
    """Heights ``(..., T, 2)`` of the right and left ankle of joints ``(..., T, 17, 3)`` above ``floor`` (a
    :class:`~platypose.lifting.floor.Floor`), or along world z without one."""
    ankles = joints[..., list(ANKLES), :]
    return floor.height(ankles) if floor is not None else np.asarray(ankles) @ np.asarray(WORLD_UP) + 0.0


def lower_height(heights: np.ndarray) -> np.ndarray:
    """The lower ankle's height ``(...)`` of ankle heights ``(..., 2)`` (an unknown one ignored)."""
    return np.fmin(heights[..., 0], heights[..., 1])


def lower_ankles(heights: np.ndarray) -> np.ndarray:
    """Which ankle is the lower, ``(..., 2)`` bool, of ankle heights ``(..., 2)``: both on a tie, never an unknown one."""
    return heights == lower_height(heights)[..., None]


def standing_heights(lower: np.ndarray, fps: float) -> np.ndarray:
    """Standing heights ``(N, T)`` of lower-ankle heights ``(N, T)`` (NaN where absent): at each frame the low
    ``STANDING_QUANTILE`` (an order statistic) over the frames within ``SUPPORT_WINDOW`` either side (a support
    that changes, as a person jumping off a roof, is followed; a jump's flight is not standing)."""
    half = max(1, round(SUPPORT_WINDOW * fps))
    lower = np.asarray(lower, dtype=np.float64)
    heights = np.full_like(lower, np.nan)
    for first in range(0, len(lower), HYPOTHESES_AT_ONCE):  # the windows' copy stays small
        rows = np.pad(lower[first : first + HYPOTHESES_AT_ONCE], ((0, 0), (half, half)), constant_values=np.nan)
        windows = np.lib.stride_tricks.sliding_window_view(rows, 2 * half + 1, axis=-1)  # (n, T, 2 half + 1)
        known = np.isfinite(windows)
        ordered = np.sort(np.where(known, windows, np.inf), axis=-1)
        count = known.sum(axis=-1)
        rank = np.floor(STANDING_QUANTILE / 100 * (count - 1)).clip(min=0).astype(np.intp)
        low = np.take_along_axis(ordered, rank[..., None], axis=-1)[..., 0]
        heights[first : first + HYPOTHESES_AT_ONCE] = np.where(count > 0, low, np.nan)
    return np.where(np.isfinite(lower), heights, np.nan)


def stance_ankles(joints: np.ndarray, floor=None, fps: float = 30.0, min_stance: float = MIN_STANCE) -> np.ndarray:
    """Which ankles stand, ``(N, T, 2)`` (right, left) for joints ``(N, T, 17, 3)`` at ``fps`` on ``floor`` (None:
    heights along world z): a hypothesis's lower ankle while within ``STANCE_BAND`` of its standing height at that
    time (:func:`standing_heights`), for at least ``min_stance`` seconds on end (0: any frame)."""
    height = ankle_heights(joints, floor)  # (N, T, 2)
    standing = standing_heights(lower_height(height), fps)[..., None]  # (N, T, 1)
    low = lower_ankles(height) & (height < standing + STANCE_BAND)
    return lasting(low, max(1, round(min_stance * fps)))


def lasting(flags: np.ndarray, frames: int) -> np.ndarray:
    """``flags`` ``(N, T, K)`` kept only within runs (along T) of at least ``frames`` true frames on end."""
    T = flags.shape[1]
    if frames <= 1:
        return flags
    if T < frames:
        return np.zeros_like(flags)
    count = np.cumsum(np.pad(flags, ((0, 0), (1, 0), (0, 0))).astype(np.int64), axis=1)  # (N, T + 1, K)
    full = (count[:, frames:] - count[:, :-frames]) == frames  # (N, T - frames + 1, K): runs starting there
    starts = np.cumsum(np.pad(full, ((0, 0), (1, 0), (0, 0))).astype(np.int64), axis=1)
    t = np.arange(T)
    first, last = np.clip(t - frames + 1, 0, T - frames + 1), np.clip(t + 1, 0, T - frames + 1)
    return (starts[:, last] - starts[:, first]) > 0  # a full run starts within frames - 1 before t, or at t
