"""ID-switch repair: swap two tracks' identities from the frame where they came close, when that makes both consistent.

A pair of tracks is examined where their keypoint boxes overlap (boxes are interpolated
across gaps, so people who are hidden or missed while they cross still count). Each
frame of such an episode where either is seen, and the first one after it, is a
candidate switch frame ``s``; there, the pairing "track before s -> track from s" is
scored for both tracks kept and for both swapped. The cost of a pairing, in units of the
person's size, has three parts: the body-shape change (mean over limb segments of |log|
of the ratio of the segment's median length over a window before and after, weighted by
``shape_weight``), the motion break (how far the straight lines fitted to the centre
before and after ``s`` are apart just before and just after it) and the pose jump at
``s`` (after moving the last pose along the fitted line). A swap is made where it lowers
the pose jump and the summed cost of both tracks by more than ``margin``, at the frame
where it lowers the pose jump most; with too few frames on either side nothing is decided.
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass

import numpy as np

from platypose.detectors.tracking.pose_metrics import person_size, pose_distance
from platypose.lifting.skeleton import JOINT_INDEX

_SEGMENT_NAMES = (
    ("right_hip", "left_hip"),
    ("left_shoulder", "right_shoulder"),
    ("right_hip", "right_knee"),
    ("right_knee", "right_ankle"),
    ("left_hip", "left_knee"),
    ("left_knee", "left_ankle"),
    ("right_shoulder", "right_elbow"),
    ("right_elbow", "right_wrist"),
    ("left_shoulder", "left_elbow"),
    ("left_elbow", "left_wrist"),
    ("right_hip", "right_shoulder"),
    ("left_hip", "left_shoulder"),
)
_SEGMENTS = np.array([[JOINT_INDEX[a], JOINT_INDEX[b]] for a, b in _SEGMENT_NAMES])
_MAX_LOG_RATIO = np.log(2.0)  # a segment twice as long (a limb swap, a bad detection) counts no more than that
_MAX_JUMP = 2.0  # a pose jump counts at most this many person sizes (a partial pose may share no joints)


@dataclass(frozen=True)
class SwitchRepairConfig:
    """ID-switch repair thresholds; costs are in units of the person's size."""

    window_s: float = 1.0  # evidence taken before and after a candidate switch frame
    horizon_s: float = 0.3  # the centre lines fitted before and after are compared this long either side of it
    min_frames: int = 3  # observed frames each track needs on each side of the switch
    bridge_s: float = 3.0  # a box is interpolated across gaps up to this long when looking for overlaps
    box_pad: float = 0.1  # boxes grow by this fraction of their longer side before the overlap test
    shape_weight: float = 2.0  # body proportions weigh more than motion (which the tracker already followed)
    margin: float = 0.5  # how much lower the swapped cost (both tracks summed) must be
    min_confidence: float = 0.2
    min_joints: int = 4


@dataclass(frozen=True)
class _Features:
    """Per-frame, per-track features of tracks (T, P, 17, 3)."""

    observed: np.ndarray  # (T, P) bool
    centre: np.ndarray  # (T, P, 2) median of the visible joints
    box: np.ndarray  # (T, P, 4) x0, y0, x1, y1 of the visible joints
    size: np.ndarray  # (T, P) person size
    segments: np.ndarray  # (T, P, S) limb segment lengths, NaN if an end is not visible


def _features(keypoints: np.ndarray, config: SwitchRepairConfig) -> _Features:
    """Centres, boxes, sizes and segment lengths of tracks (T, P, 17, 3)."""
    visible = keypoints[..., 2] > config.min_confidence
    xy = np.where(visible[..., None], keypoints[..., :2], np.nan).astype(np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        centre = np.nanmedian(xy, axis=-2)
        box = np.concatenate([np.nanmin(xy, axis=-2), np.nanmax(xy, axis=-2)], axis=-1)
    segments = np.linalg.norm(xy[..., _SEGMENTS[:, 0], :] - xy[..., _SEGMENTS[:, 1], :], axis=-1)
    observed = visible.sum(axis=-1) >= config.min_joints
    return _Features(observed, centre, box, person_size(keypoints, config.min_confidence), segments)


def _bridged(values: np.ndarray, observed: np.ndarray, times: np.ndarray, bridge_s: float) -> np.ndarray:
    """Per-frame values (T, D) of one track, linearly interpolated across its gaps up to ``bridge_s``; NaN elsewhere."""
    frames = np.flatnonzero(observed)
    out = np.full(values.shape, np.nan)
    out[frames] = values[frames]
    for first, last in itertools.pairwise(frames):
        if last - first > 1 and times[last] - times[first] <= bridge_s:
            weight = (times[first + 1 : last] - times[first]) / (times[last] - times[first])
            out[first + 1 : last] = values[first] + weight[:, None] * (values[last] - values[first])
    return out


def _close_episodes(
    features: _Features, times: np.ndarray, config: SwitchRepairConfig
) -> list[tuple[int, int, int, int]]:
    """Runs of frames where two tracks' (padded, bridged) boxes overlap: (first frame, last frame, a, b), by first
    frame."""
    pad = config.box_pad * np.max(features.box[..., 2:] - features.box[..., :2], axis=-1, keepdims=True)
    padded = features.box + np.concatenate([-pad, -pad, pad, pad], axis=-1)
    num_persons = features.observed.shape[1]
    boxes = [_bridged(padded[:, p], features.observed[:, p], times, config.bridge_s) for p in range(num_persons)]
    episodes = []
    for a in range(num_persons):
        for b in range(a + 1, num_persons):
            with np.errstate(invalid="ignore"):
                lower = np.fmax(boxes[a][:, :2], boxes[b][:, :2])
                overlap = (np.minimum(boxes[a][:, 2:], boxes[b][:, 2:]) > lower).all(axis=-1)
            close = np.concatenate([[False], overlap, [False]])
            edges = np.flatnonzero(np.diff(close.astype(np.int8)))
            episodes += [(int(first), int(end) - 1, a, b) for first, end in zip(edges[::2], edges[1::2])]
    return sorted(episodes)


def _fit_line(t: np.ndarray, xy: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The straight line fitted (least squares) to points (N, 2) at times (N,), evaluated at times (M,) -> (M, 2)."""
    design = np.stack([np.ones_like(t), t - t.mean()], axis=1)
    coefficients = np.linalg.lstsq(design, xy, rcond=None)[0]
    return coefficients[0] + np.outer(at - t.mean(), coefficients[1])


def _evidence_frames(
    observed: np.ndarray, times: np.ndarray, s: int, after: bool, config: SwitchRepairConfig
) -> np.ndarray:
    """Observed frames of one track (T,) bool before frame s (or from s on): those within ``window_s`` of the one
    nearest to s, if that one is within ``bridge_s`` of s; else none."""
    frames = s + np.flatnonzero(observed[s:]) if after else np.flatnonzero(observed[:s])
    if len(frames) == 0:
        return frames
    nearest = times[frames[0] if after else frames[-1]]
    if abs(nearest - times[s]) > config.bridge_s:
        return frames[:0]
    return frames[np.abs(times[frames] - nearest) <= config.window_s]


def _column_medians(values: np.ndarray) -> np.ndarray:
    """Median of each column of (N, S) over its finite values, (S,); NaN for a column with none (np.nanmedian, faster
    on small arrays)."""
    ordered = np.sort(values, axis=0)  # NaN sorts last
    count = np.isfinite(values).sum(axis=0)
    columns = np.arange(values.shape[1])
    low = ordered[np.maximum(count - 1, 0) // 2, columns]
    high = ordered[count // 2, columns]
    return np.where(count > 0, (low + high) / 2, np.nan)


def _pairing_cost(
    keypoints: np.ndarray,
    features: _Features,
    times: np.ndarray,
    s: int,
    before: int,
    after: int,
    config: SwitchRepairConfig,
) -> np.ndarray:
    """Cost of track ``before`` up to frame s continuing as track ``after`` from s: (shape + motion, pose jump), (2,);
    NaN if either side has too few observed frames."""
    frames_before = _evidence_frames(features.observed[:, before], times, s, False, config)
    frames_after = _evidence_frames(features.observed[:, after], times, s, True, config)
    if len(frames_before) < config.min_frames or len(frames_after) < config.min_frames:
        return np.full(2, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.log(
            _column_medians(features.segments[frames_before, before])
            / _column_medians(features.segments[frames_after, after])
        )
    ratio = np.abs(ratio[np.isfinite(ratio)])
    shape = float(np.mean(np.minimum(ratio, _MAX_LOG_RATIO))) if len(ratio) >= 3 else 0.0
    scale = float(
        np.sqrt(np.median(features.size[frames_before, before]) * np.median(features.size[frames_after, after]))
    )
    last, first = frames_before[-1], frames_after[0]
    at = np.array([times[last] - config.horizon_s, times[first] + config.horizon_s, times[last], times[first]])
    line_before = _fit_line(times[frames_before], features.centre[frames_before, before], at)
    line_after = _fit_line(times[frames_after], features.centre[frames_after, after], at[:2])
    motion = float(np.mean(np.linalg.norm(line_before[:2] - line_after, axis=-1)))
    predicted = keypoints[last, before].astype(np.float64)
    predicted[:, :2] += line_before[3] - line_before[2]
    jump = pose_distance(predicted, keypoints[first, after], config.min_confidence)
    return np.array([config.shape_weight * shape + motion / scale, min(jump, _MAX_JUMP)])


def _switch_saving(
    keypoints: np.ndarray, features: _Features, times: np.ndarray, s: int, a: int, b: int, config: SwitchRepairConfig
) -> np.ndarray:
    """Cost of keeping tracks a and b at frame s minus the cost of swapping them from s on, as (shape + motion,
    pose jump), (2,); NaN if undecidable."""
    keep = _pairing_cost(keypoints, features, times, s, a, a, config)
    keep += _pairing_cost(keypoints, features, times, s, b, b, config)
    swap = _pairing_cost(keypoints, features, times, s, a, b, config)
    swap += _pairing_cost(keypoints, features, times, s, b, a, config)
    return keep - swap


def _candidate_frames(observed: np.ndarray, first: int, last: int) -> np.ndarray:
    """Frames a switch may take effect at for an episode [first, last]: the observed ones (T,) bool in it, and the
    first observed one after it (a switch during a gap shows there)."""
    inside = first + np.flatnonzero(observed[first : last + 1])
    later = last + 1 + np.flatnonzero(observed[last + 1 :])[:1]
    candidates = np.concatenate([inside, later])
    return candidates[candidates > 0]


def repair_id_switches(
    keypoints: np.ndarray, frame_times: np.ndarray, config: SwitchRepairConfig = SwitchRepairConfig()
) -> tuple[np.ndarray, list[tuple[int, int, int]]]:
    """Tracks (T, P, 17, 3) -> (tracks with switched identities swapped back, the swaps made as (frame, a, b))."""
    times = np.asarray(frame_times, dtype=np.float64)
    repaired = keypoints.copy()
    features = _features(repaired, config)
    swaps = []
    episodes = _close_episodes(features, times, config)
    for first, last, a, b in episodes:
        for s_done, x, y in swaps:  # a swap moved the people it swapped to each other's columns from its frame on
            if first >= s_done:
                a, b = ({x: y, y: x}.get(p, p) for p in (a, b))
        candidates = _candidate_frames(features.observed[:, [a, b]].any(axis=1), first, last)
        if len(candidates) == 0:
            continue
        savings = np.array([_switch_saving(repaired, features, times, s, a, b, config) for s in candidates])
        # a switch shows as a pose jump that swapping removes; among such frames, the biggest jump saved marks it
        switch = (savings.sum(axis=1) > config.margin) & (savings[:, 1] > 0)
        if not switch.any():
            continue
        s = int(candidates[np.flatnonzero(switch)[np.argmax(savings[switch, 1])]])
        repaired[s:, [a, b]] = repaired[s:, [b, a]]
        features = _features(repaired, config)
        swaps.append((s, a, b))
    return repaired, swaps
