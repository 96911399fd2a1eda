"""Frames lifted through a detection gap are marked as filled by the prior (exporters/gaps.py), on real tracks."""

import numpy as np

from platypose.exporters.gaps import fill_plan, find_gaps
from platypose.lifting.tracks.roots import presence, seen_frames


def test_the_roof_mans_gap_is_marked_as_filled_by_the_prior(data_dir):
    """The Sports2D demo's man is unseen in frames 123-167 (1.5 s): under the default --max-gap he is present there
    (lifted through), and the gap rule marks those frames "prior" and filled, not interpolated or held."""
    from platypose.detectors.cache import read_detections
    from platypose.detectors.keypoints import to_our_joints
    from platypose.detectors.tracking.tracker import track_detections

    _, detections, indices = read_detections(data_dir / "video/sports2d-demo/movenet-detections.npz")
    tracks = track_detections([to_our_joints(p, "coco17") for p in detections], indices / 30.0, (994, 1768), "demo")
    keypoints, times = tracks.keypoints[None], tracks.frame_times
    present, seen = presence(keypoints, times, 5.0)[0], seen_frames(keypoints)[0]
    plan = fill_plan(present, times, seen)
    gaps = [(g.first, g.last, g.how) for g in find_gaps(plan, times)]
    assert (123, 167, "prior") in gaps
    assert (226, len(times) - 1, "held") in gaps
    assert plan.filled[123:168].all() and not plan.filled[120:123].any()
    assert not np.isin([g.how for g in find_gaps(fill_plan(present, times), times)], ["prior"]).any()
