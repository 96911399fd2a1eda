"""A person placed behind a camera that sees them is impossible geometry, flagged once with its figures: upside-down
keypoints or all joints at one pixel can be reprojected by a body behind the lens, so the depth's sign decides."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from export_helpers import camera_facing, climb_joints

from platypose.lifting.checks.flags import flag_text, person_lines
from platypose.lifting.checks.plausibility import plausibility

DATA = Path(__file__).resolve().parents[2] / "data"


def take(behind: bool):
    """A real climb seen by a camera 4 m in front of it; with ``behind``, mirrored through the camera centre (the
    same image up to a flip, the body behind the lens)."""
    joints, _ = climb_joints(DATA, 30)
    camera = camera_facing(joints)
    centre = camera.center
    placed = 2 * centre - joints if behind else joints
    keypoints = np.zeros((1, len(joints), 1, 17, 3))
    keypoints[0, :, 0, :, 2] = 0.9
    keypoints[0, :, 0, :, :2] = 500.0  # what the detector saw does not matter to the depth rule
    hypotheses = np.repeat(placed[None, None], 3, axis=1)
    return hypotheses, keypoints, placed[None], camera


def test_a_body_behind_the_camera_is_flagged_with_its_depth() -> None:
    hypotheses, keypoints, median, camera = take(behind=True)
    (report,) = plausibility(hypotheses, keypoints, None, 30.0, median=median, cameras=[camera])
    assert "behind camera" in report["flags"]
    assert report["behind_camera_share"] == 1.0 and report["pelvis_depth_median_m"] < -3.0
    assert (
        "behind camera (the pelvis lies behind a camera that sees them in 100% of frames, median depth -"
        in (report["flag_text"])
    )
    lines = person_lines([report], [5])
    assert len(lines) == 1 and lines[0].startswith("person 5: flagged: ") and "behind camera" in lines[0]


def test_a_body_in_front_is_not_flagged() -> None:
    hypotheses, keypoints, median, camera = take(behind=False)
    (report,) = plausibility(hypotheses, keypoints, None, 30.0, median=median, cameras=[camera])
    assert "behind camera" not in report["flags"] and report["pelvis_depth_median_m"] > 3.0
    assert report["behind_camera_share"] == 0.0 and "behind" not in flag_text(report)
