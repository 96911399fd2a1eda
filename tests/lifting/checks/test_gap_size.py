"""A person's body across a gap: flagged once when the keypoints after it give another body than before it."""

from __future__ import annotations

import numpy as np

from platypose.lifting.calibration import load_calibration
from platypose.lifting.checks.flags import flag_text
from platypose.lifting.checks.gap_size import body_sizes, size_after_gap

DEMO = "video/sports2d-demo"


def _man(data_dir) -> tuple[np.ndarray, np.ndarray]:
    """The Sports2D man of a real calibrated lift ``(1, 3, 226, 17, 3)`` (three sizes of one body, NaN in his 1.5 s
    gap) and the joints the camera sees of him per frame, from the bundled detections."""
    from platypose.detectors.cache import read_detections
    from platypose.detectors.keypoints import to_our_joints
    from platypose.detectors.tracking.tracker import track_detections

    _, detections, indices = read_detections(data_dir / DEMO / "movenet-detections.npz")
    tracks = track_detections([to_our_joints(p, "coco17") for p in detections], indices / 30.0, (994, 1768), "demo")
    seen = (np.nan_to_num(tracks.keypoints[:, 0, :, 2]) > 0).sum(-1)[:226]
    man = np.load(data_dir.parent / "tests/data/lifts/sports2d_demo_medians.npy")[0, :226].astype(np.float64)
    camera = load_calibration(data_dir / DEMO / "Calib_demo.toml").cameras[0]
    return np.stack([camera.center + s * (man - camera.center) for s in (1.0, 1.04, 0.96)])[None], seen


def test_a_body_larger_after_the_gap_is_flagged_once_with_the_gap(data_dir):
    """One body on both sides of the roof man's gap (the lift made it rigid): nothing said. His frames after the gap
    scaled 1.45 times about the camera (the images unchanged, the body 1.45 times larger, as the floor contact made
    it before the bodies agreed): flagged with the gap's frames and the ratio, in one sentence."""
    hypotheses, seen = _man(data_dir)
    camera = load_calibration(data_dir / DEMO / "Calib_demo.toml").cameras[0]
    assert size_after_gap(body_sizes(hypotheses, 0), seen, 30.0) is None
    hypotheses[:, :, 168:] = camera.center + 1.45 * (hypotheses[:, :, 168:] - camera.center)
    gap = size_after_gap(body_sizes(hypotheses, 0), seen, 30.0)
    assert gap == {"first_frame": 123, "last_frame": 167, "ratio": 1.45}, gap
    report = {"flags": ["size after gap"], "size_after_gap": gap}
    assert "after the gap in frames 123-167 the keypoints give a body 1.45 times the one before it" in flag_text(report)
