"""A take's 2D keypoints: the views' tracks matched across cameras, the chosen persons, one clock.

:func:`take_keypoints` turns the tracks of C views (:class:`~platypose.detectors.types.PoseTrack2D`,
with their calibrated cameras) into one array ``(C, T, P, 17, 3)`` on the first view's
frames, the persons matched across views by triangulation and the ``persons`` choice
applied (all, largest, or the N largest).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from platypose.detectors.tracking.tracker import persons_to_keep
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.calibration.matching import gather_views
from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError

RATE_TOLERANCE = 0.05  # views whose median frame steps differ more than this are at different frame rates


def check_frame_rates(views: Sequence[PoseTrack2D], source: str) -> None:
    """InputError when the views are at different frame rates: each view's frames are matched to the first view's
    one by one, so a 30 fps view beside a 60 fps one would lose half its frames (or its persons)."""
    steps = [float(np.median(np.diff(v.frame_times))) for v in views if v.num_frames > 1]
    if len(steps) > 1 and (max(steps) - min(steps)) > RATE_TOLERANCE * min(steps):
        rates = ", ".join(f"{1 / s:.3g}" for s in steps)
        raise InputError(
            f"{source}: the views are at different frame rates ({rates} fps); give them at one rate "
            "(re-encode the videos, or read the keypoints with one --fps)"
        )


def take_keypoints(
    views: Sequence[PoseTrack2D], cameras: Sequence[Camera], persons: str = "all", source: str = "input"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Keypoints (C, T, P, 17, 3) of the chosen persons on the first view's clock, frame times (T,), track IDs (P,).

    A view's frame counts as the first view's when it lies within half a frame of it
    (each camera's ``time_offset_s`` applied). InputError naming ``source`` when no person is left.
    """
    check_frame_rates(views, source)
    if len(views) > 1:
        from platypose.detectors.persons.multiview import match_across_views

        views = match_across_views(views, cameras)
    keep = persons_to_keep(views, persons)
    views = views if keep is None else [v.select(keep) for v in views]
    if views[0].num_persons == 0:
        raise InputError(f"{source}: no person found")
    step = np.median(np.diff(views[0].frame_times)) if views[0].num_frames > 1 else 1.0
    gathered = gather_views([v.keypoints for v in views], [v.frame_times for v in views], cameras, 0.5 * step)
    return np.stack(gathered), views[0].frame_times, views[0].track_ids
