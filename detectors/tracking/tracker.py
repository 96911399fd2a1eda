"""Multi-person tracking: persistent IDs from per-frame detections, gap bridging, fragment repair, selection.

Per frame, each live track predicts its pose with constant per-joint velocity;
tracks and detections are assigned by the Hungarian method on the median
keypoint distance divided by the person's size. A track survives unseen for up
to ``max_gap_s`` (its ID bridges the gap; the gap frames stay missing). After
the pass, a fragment that ends and one that starts within ``stitch_gap_s``
are joined when the pose moved less than ``stitch_cost + stitch_speed * gap``
person sizes (repairs the ID switches left by occlusions and missed
detections); best pairs first, each fragment joined at most once per end.
Tracks with fewer than ``min_track_frames`` observed frames are dropped. Last,
with ``repair_switches``, two tracks that came close and switched identities are
swapped back from the switch on (``detectors.tracking.id_repair``). With ``repair_sides``, frames where the detector
labelled a person's left as their right are relabelled (``detectors.tracking.side_swaps``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from platypose.detectors.keypoints import missing_persons
from platypose.detectors.persons.person_choice import check_point_in_image, indices_of_ids, nearest_track, parse_persons
from platypose.detectors.tracking.id_repair import SwitchRepairConfig, repair_id_switches
from platypose.detectors.tracking.pose_metrics import person_size, pose_distance
from platypose.detectors.tracking.side_swaps import repair_side_swaps
from platypose.detectors.types import PoseTrack2D

_NO_MATCH = 1e6


@dataclass(frozen=True)
class TrackerConfig:
    """Tracking thresholds; distances are in units of the person's size (square root of box area)."""

    max_cost: float = 0.6
    max_gap_s: float = 1.0
    stitch_gap_s: float = 3.0
    stitch_cost: float = 0.8
    stitch_speed: float = 2.0  # person sizes per second a fragment's end may move to the next one's start
    min_joints: int = 4
    min_confidence: float = 0.2
    min_track_frames: int = 3
    repair_switches: bool = True  # swap identities back where two tracks that came close were switched
    repair_sides: bool = True  # undo the detector's left/right label swaps (detectors.tracking.side_swaps)


@dataclass
class _Track:
    frames: list[int] = field(default_factory=list)
    poses: list[np.ndarray] = field(default_factory=list)

    def predict(self, time: float, times: np.ndarray) -> np.ndarray:
        """Constant-velocity prediction of the pose (17, 3) at ``time``."""
        last = self.poses[-1]
        if len(self.poses) < 2:
            return last
        dt = times[self.frames[-1]] - times[self.frames[-2]]
        velocity = (last[:, :2] - self.poses[-2][:, :2]) / max(dt, 1e-6)
        median_velocity = np.nanmedian(velocity, axis=0) if np.isfinite(velocity).any() else np.zeros(2)
        velocity = np.where(np.isfinite(velocity), velocity, median_velocity)
        predicted = last.copy()
        predicted[:, :2] += velocity * (time - times[self.frames[-1]])
        return predicted


def _assign(
    tracks: list[_Track],
    detections: np.ndarray,
    time: float,
    times: np.ndarray,
    gates: np.ndarray,
    min_confidence: float,
) -> list[tuple[int, int]]:
    """Hungarian assignment of live tracks to detections (N, 17, 3) under per-track gates; (track, detection) pairs."""
    if not tracks or len(detections) == 0:
        return []
    cost = np.full((len(tracks), len(detections)), _NO_MATCH)
    for i, track in enumerate(tracks):
        predicted = track.predict(time, times)
        for j, detection in enumerate(detections):
            c = pose_distance(predicted, detection, min_confidence)
            if c < gates[i]:
                cost[i, j] = c
    rows, cols = linear_sum_assignment(cost)
    return [(int(r), int(c)) for r, c in zip(rows, cols) if cost[r, c] < _NO_MATCH]


def _online_tracks(detections: list[np.ndarray], times: np.ndarray, config: TrackerConfig) -> list[_Track]:
    """First pass: frame-by-frame assignment with motion prediction and gap bridging."""
    finished: list[_Track] = []
    live: list[_Track] = []
    for t, frame in enumerate(detections):
        still_live = []
        for track in live:
            (finished if times[t] - times[track.frames[-1]] > config.max_gap_s else still_live).append(track)
        live = still_live
        gaps = np.array([times[t] - times[track.frames[-1]] for track in live])
        gates = config.max_cost * (1.0 + gaps / config.max_gap_s)
        pairs = _assign(live, frame, times[t], times, gates, config.min_confidence)
        matched = {j for _, j in pairs}
        for i, j in pairs:
            live[i].frames.append(t)
            live[i].poses.append(frame[j])
        for j, detection in enumerate(frame):
            if j not in matched and (detection[:, 2] > config.min_confidence).sum() >= config.min_joints:
                live.append(_Track([t], [detection]))
    return finished + live


def _stitch(tracks: list[_Track], times: np.ndarray, config: TrackerConfig) -> list[_Track]:
    """Join fragments end-to-start (greedy by cost) when the gap is short and the pose jump small for that gap."""
    candidates = []
    for a, first in enumerate(tracks):
        for b, second in enumerate(tracks):
            gap = times[second.frames[0]] - times[first.frames[-1]]
            if a != b and 0 < gap <= config.stitch_gap_s:
                cost = pose_distance(first.poses[-1], second.poses[0], config.min_confidence)
                if cost < config.stitch_cost + config.stitch_speed * gap:
                    candidates.append((cost, a, b))
    successor: dict[int, int] = {}
    predecessor: dict[int, int] = {}
    for _, a, b in sorted(candidates):
        if a in successor or b in predecessor:
            continue
        successor[a] = b
        predecessor[b] = a
    joined = []
    for start in range(len(tracks)):
        if start in predecessor:
            continue
        track, node = _Track(), start
        while True:
            track.frames += tracks[node].frames
            track.poses += tracks[node].poses
            if node not in successor:
                break
            node = successor[node]
        joined.append(track)
    return joined


def track_detections(
    detections: list[np.ndarray],
    frame_times: np.ndarray,
    image_size: tuple[int, int],
    source: str,
    config: TrackerConfig = TrackerConfig(),
) -> PoseTrack2D:
    """Per-frame detections (list over T of (N_t, 17, 3), our joints) -> tracks with persistent IDs.

    IDs are 0..P-1 in order of first appearance.
    """
    times = np.asarray(frame_times, dtype=np.float64)
    if len(detections) != len(times):
        raise ValueError(f"{len(detections)} detection frames but {len(times)} frame times")
    tracks = _stitch(_online_tracks(detections, times, config), times, config)
    tracks = [track for track in tracks if len(track.frames) >= config.min_track_frames]
    tracks.sort(key=lambda track: track.frames[0])
    keypoints = missing_persons(len(times), len(tracks))
    for p, track in enumerate(tracks):
        keypoints[track.frames, p] = np.stack(track.poses)
    if config.repair_switches:
        repair = SwitchRepairConfig(min_confidence=config.min_confidence, min_joints=config.min_joints)
        keypoints = repair_id_switches(keypoints, times, repair)[0]
    if config.repair_sides:
        keypoints = repair_side_swaps(keypoints)[0]
    return PoseTrack2D(keypoints, times, np.arange(len(tracks)), image_size, source)


def persons_count(persons: str) -> int | None:
    """Check a ``persons`` choice (:func:`platypose.lifting.settings.choices.parse_persons`; InputError if bad): N for
    ``largest`` (1) or ``largest:N``, None for the others (all, ids, a point)."""
    kind, value = parse_persons(persons)
    return value if kind == "count" else None


def persons_to_keep(views: Sequence[PoseTrack2D], persons: str) -> np.ndarray | None:
    """Indices along P (shared by the views) of the ``persons`` choice (:mod:`platypose.detectors.persons.person_choice`):
    the largest first by size summed over frames and views, the tracks of given ids, or the track nearest a pixel
    of the first view where it is first seen; None for ``all``."""
    kind, value = parse_persons(persons)
    if kind == "all":
        return None
    if kind == "ids":
        return indices_of_ids(views[0].track_ids, value)
    if kind == "point":
        check_point_in_image(value, views[0].image_size)
        return np.array([nearest_track(views[0].keypoints, value)], dtype=np.intp)
    score = sum(np.nansum(person_size(view.keypoints), axis=0) for view in views)
    return np.sort(np.argsort(-score, kind="stable")[:value])


def select_persons(tracks: PoseTrack2D, persons: str) -> PoseTrack2D:
    """Keep the tracks of the ``persons`` choice (:func:`persons_to_keep`) of ``tracks``."""
    keep = persons_to_keep([tracks], persons)
    return tracks if keep is None else tracks.select(keep)


def tracks_from_ids(
    ids: list[np.ndarray],
    detections: list[np.ndarray],
    frame_times: np.ndarray,
    image_size: tuple[int, int],
    source: str,
) -> PoseTrack2D:
    """Per-frame people (N_t, 17, 3) that already carry track IDs (N_t,) -> tracks, one per distinct ID (sorted).

    A repeated ID within one frame is a ValueError.
    """
    all_ids = np.unique(np.concatenate([np.asarray(i, dtype=np.int64) for i in ids])) if ids else np.zeros(0, int)
    column = {int(track_id): p for p, track_id in enumerate(all_ids)}
    keypoints = missing_persons(len(detections), len(all_ids))
    for t, (frame_ids, people) in enumerate(zip(ids, detections)):
        if len(set(np.asarray(frame_ids).tolist())) != len(frame_ids):
            raise ValueError(f"frame {t} has the same track ID twice")
        for track_id, pose in zip(np.asarray(frame_ids).tolist(), people):
            keypoints[t, column[int(track_id)]] = pose
    return PoseTrack2D(keypoints, frame_times, all_ids, image_size, source)
