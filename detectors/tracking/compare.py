"""Compare tracks with reference keypoints of the same video (e.g. a detector against shipped OpenPose JSON)."""

from __future__ import annotations

import numpy as np

from platypose.detectors.types import PoseTrack2D
from platypose.lifting.calibration.matching import align_frames


def distances_to_reference(tracks: PoseTrack2D, reference: PoseTrack2D, person: int) -> np.ndarray:
    """Pixel distances (T_ref, 17) from reference person ``person`` to the track that is nearest in each frame.

    Frames are paired by time (within half a reference frame); the nearest track is the one with
    the smallest median joint distance. NaN where the frame, the joint or every track is missing.
    """
    step = np.median(np.diff(reference.frame_times)) if reference.num_frames > 1 else np.inf
    index = align_frames(reference.frame_times, tracks.frame_times, 0.5 * step)
    out = np.full((reference.num_frames, 17), np.nan)
    for t, k in enumerate(index):
        ref = reference.keypoints[t, person]
        if k < 0 or tracks.num_persons == 0:
            continue
        candidates = tracks.keypoints[k]  # (P, 17, 3)
        seen = (candidates[..., 2] > 0) & (ref[:, 2] > 0)
        distance = np.where(seen, np.linalg.norm(candidates[..., :2] - ref[:, :2], axis=-1), np.nan)
        if np.isfinite(distance).any():
            medians = np.array([np.nanmedian(d) if np.isfinite(d).any() else np.inf for d in distance])
            out[t] = distance[int(np.argmin(medians))]
    return out
