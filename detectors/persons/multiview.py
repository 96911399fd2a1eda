"""Match people across calibrated views: one ID per person in every view, by triangulation consistency.

For a group of tracks in different views, the joints seen by two or more of
them on common-clock frames are triangulated and reprojected; the median
reprojection error over the person's size (pixels) is the group's cost. Pairs
are merged best first (union of groups) when the pair and the merged group both
cost less than ``max_error`` and no group would hold two tracks of one view (a
third view catches what two views cannot: a shift along the epipolar line). A
person seen by one camera only keeps a group of its own.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from platypose.detectors.keypoints import missing_persons
from platypose.detectors.tracking.tracker import person_size
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.calibration.matching import gather_views
from platypose.lifting.camera import Camera
from platypose.lifting.triangulation import reprojection_errors, triangulate

MIN_SHARED = 20  # joint observations two tracks must share to be compared
FRAME_BLOCK = 1024  # frames triangulated and reprojected at a time: memory stays bounded for long takes


def group_cost(tracks: Sequence[np.ndarray], cameras: Sequence[Camera]) -> float:
    """Median reprojection error / person size of tracks (T, 17, 3) of one person in several views; inf if unsure.

    Joints seen by at least two of the views are triangulated from all views that see them.
    """
    keypoints = np.stack(tracks)  # (C, T, 17, 3)
    seen = keypoints[..., 2] > 0
    shared = seen.sum(axis=0) >= 2
    if shared.sum() < MIN_SHARED:
        return np.inf
    confidence = np.where(shared, keypoints[..., 2], 0.0)
    errors = np.concatenate(
        [
            _errors(keypoints[:, t : t + FRAME_BLOCK], confidence[:, t : t + FRAME_BLOCK], cameras)
            for t in range(0, keypoints.shape[1], FRAME_BLOCK)
        ],
        axis=1,
    )
    usable = seen & shared & np.isfinite(errors)
    if usable.sum() < MIN_SHARED:
        return np.inf
    size = np.nanmedian(np.fmax.reduce(person_size(keypoints), axis=0))
    return float(np.median(errors[usable]) / size)


def _errors(keypoints: np.ndarray, confidence: np.ndarray, cameras: Sequence[Camera]) -> np.ndarray:
    """Reprojection errors (C, T, 17) of the points triangulated from keypoints (C, T, 17, 3) with ``confidence``."""
    points = triangulate(keypoints[..., :2], confidence, cameras)
    return reprojection_errors(points, keypoints[..., :2], cameras)


def match_across_views(
    views: Sequence[PoseTrack2D], cameras: Sequence[Camera], max_error: float = 0.06
) -> list[PoseTrack2D]:
    """Per-view tracks -> per-view tracks sharing person IDs (0..K-1, same P in every view, missing where unseen).

    ``cameras[c]`` is the calibrated camera of ``views[c]``; frames are compared on the
    common clock (``time_offset_s``) within half a frame of the first view.
    """
    if len(views) != len(cameras):
        raise ValueError(f"{len(views)} views but {len(cameras)} cameras")
    step = np.median(np.diff(views[0].frame_times)) if views[0].num_frames > 1 else 1.0
    aligned = gather_views(
        [v.keypoints for v in views], [v.frame_times for v in views], cameras, tolerance_s=0.5 * step
    )
    nodes = [(c, p) for c, view in enumerate(views) for p in range(view.num_persons)]

    def cost(members: list[int]) -> float:
        return group_cost(
            [aligned[nodes[n][0]][:, nodes[n][1]] for n in members], [cameras[nodes[n][0]] for n in members]
        )

    candidates = sorted(
        (cost([i, k]), i, k) for i in range(len(nodes)) for k in range(i + 1, len(nodes)) if nodes[i][0] != nodes[k][0]
    )
    group = list(range(len(nodes)))

    def root(n: int) -> int:
        while group[n] != n:
            n = group[n]
        return n

    for pair, i, k in candidates:
        a, b = root(i), root(k)
        members = [n for n in range(len(nodes)) if root(n) in (a, b)]
        views_seen = [nodes[n][0] for n in members]
        if pair < max_error and a != b and len(set(views_seen)) == len(views_seen) and cost(members) < max_error:
            group[max(a, b)] = min(a, b)
    roots = sorted({root(n) for n in range(len(nodes))})
    person = {r: i for i, r in enumerate(roots)}
    matched = []
    for c, view in enumerate(views):
        keypoints = missing_persons(view.num_frames, len(roots))
        for p in range(view.num_persons):
            keypoints[:, person[root(nodes.index((c, p)))]] = view.keypoints[:, p]
        matched.append(
            PoseTrack2D(keypoints, view.frame_times, np.arange(len(roots)), view.image_size, view.source, view.notes)
        )
    return matched
