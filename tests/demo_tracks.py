"""Shared test material: the Sports2D demo's bundled MoveNet detections tracked (one view, 230 frames at 30 fps:
the man on the roof, lost for 1.5 s while he jumps down, and the woman who walks in after 1.3 s and out before the
end) and the take they make under the demo's default camera."""

from __future__ import annotations

import numpy as np

from platypose.data import VIDEO_DIR
from platypose.detectors.types import PoseTrack2D


def demo_tracks() -> PoseTrack2D:
    """The demo's detections tracked: keypoints (230, 2, 17, 3), frame times, image size (994, 1768)."""
    from platypose.detectors.cache import read_detections
    from platypose.detectors.keypoints import to_our_joints
    from platypose.detectors.tracking.tracker import track_detections

    _, detections, indices = read_detections(VIDEO_DIR / "sports2d-demo/movenet-detections.npz")
    return track_detections([to_our_joints(p, "coco17") for p in detections], indices / 30.0, (994, 1768), "demo")


def demo_take(sampler, windows, repeats: int = 1):
    """The take of both persons of :func:`demo_tracks` (repeated ``repeats`` times on one clock) seen by the demo's
    default camera, their roots solved, lifted as ``sampler`` and ``windows`` say."""
    from platypose.lifting.calibration.defaults import default_camera
    from platypose.lifting.take import Take

    tracks = demo_tracks()
    keypoints = np.concatenate([tracks.keypoints] * repeats)[None]  # (1, T, 2, 17, 3)
    length = tracks.frame_times[-1] - tracks.frame_times[0] + 1 / 30.0
    times = np.concatenate([tracks.frame_times + k * length for k in range(repeats)])
    camera = default_camera("demo", *tracks.image_size)
    return Take.on_clock(keypoints, times, np.arange(2), [camera], [None, None], sampler=sampler, windows=windows)
