"""One uncalibrated view's camera, estimated from its people (:mod:`platypose.lifting.calibration.from_people`) with the
focal length of its lens (:mod:`platypose.lifting.calibration.lens`), as a camera in the estimated world (z up,
the floor z = 0, the camera on the z axis looking along +y), and the sentence that says what was found.

Experimental: ``lift`` does not call :func:`fit_view` (without ``--cams`` it assumes a default camera,
:mod:`platypose.lifting.calibration.defaults`); ``tools/camera_errors.py`` does, to compare its estimates with a
calibration.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.calibration.from_people import MIN_OBSERVATIONS, CameraEstimate, estimate_camera
from platypose.lifting.calibration.lens import METADATA, lens_focal
from platypose.lifting.calibration.pose_above_floor import pitched, posed_camera
from platypose.lifting.camera import Camera


def estimate_note(estimate: CameraEstimate) -> str:
    """The camera found, with each quantity's spread (log, meta, report)."""
    sd = estimate.sd
    return (
        f"camera estimated from {estimate.persons} person(s) in {estimate.observations} upright person-frames "
        f"({estimate.rejected} left out): {pitched(estimate.pitch_deg, sd['pitch_deg'])}, "
        f"rolled {estimate.roll_deg:.1f} +- {sd['roll_deg']:.1f}, focal length {estimate.focal_px:.0f} +- "
        f"{sd['focal_px']:.0f} px (from the {estimate.focal_source}), {estimate.height_m:.2f} +- "
        f"{sd['height_m']:.2f} m above the floor"
    )


def fit_view(
    name: str, keypoints: np.ndarray, times: np.ndarray, size: tuple[int, int], tags: dict[str, str]
) -> tuple[Camera | None, CameraEstimate | None, str]:
    """The camera of view ``name`` from its keypoints (T, P, 17, 3) on ``times``, image ``size`` (h, w) and video
    metadata ``tags``, the estimate, and one sentence; the camera is None (the sentence says why) when too few
    person-frames are seen upright or they disagree."""
    focal, source = lens_focal(tags, size)
    estimate = estimate_camera(keypoints, times, size, focal, source, hold_focal=source == METADATA)
    if estimate is None:
        return (
            None,
            None,
            (f"camera not estimated: fewer than {MIN_OBSERVATIONS} person-frames show ankles, pelvis, thorax and head"),
        )
    if estimate.problem is not None:
        return None, estimate, f"camera not estimated: {estimate.problem}"
    camera = posed_camera(name, size, estimate.focal_px, estimate.pitch_deg, estimate.roll_deg, estimate.height_m)
    return camera, estimate, estimate_note(estimate)
