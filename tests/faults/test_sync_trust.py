"""``--sync auto`` applies only offsets it can trust: a low-confidence estimate, or a large shift of middling
confidence, keeps the calibration's offset and says so; views where nobody is seen raise no NumPy warning."""

from __future__ import annotations

import re
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from platypose.detectors.sources.keypoint_source import read_keypoints
from platypose.lifting.calibration import load_calibration
from platypose.lifting.sync.choice import synchronise, trusted_offsets
from platypose.pipeline import match_cameras

TAKE = Path(__file__).resolve().parents[2] / "data/video/pose2sim-balancing"
NAMES = ["cam01", "cam02", "cam03", "cam04"]


def test_a_synchronised_take_with_unreliable_motion_keeps_its_offsets() -> None:
    """The bundled take is synchronised; with noisy keypoints (and one view seen every other frame) the motion
    estimates are -31 and +17 frames at confidence 0.02-0.04: none is applied, each is said, no RuntimeWarning."""
    tracks = [read_keypoints(TAKE / "openpose-body25b" / f"{n}_json", 60.0, (1088, 1920)) for n in NAMES]
    cameras = match_cameras(load_calibration(TAKE / "calib_pose2sim.toml"), NAMES, "take", "calib")
    keypoints = [t.keypoints.copy() for t in tracks]
    rng = np.random.default_rng(0)
    for k in keypoints[1:]:
        k[..., :2] += rng.normal(0, 40, k[..., :2].shape)
    keypoints[3][::2] = np.nan
    keypoints[3][::2, ..., 2] = 0
    said: list[str] = []
    logged: list[str] = []
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        synced = synchronise("auto", keypoints, [t.frame_times for t in tracks], cameras, logged.append, said.append)
    assert synced.record()["offsets_s"] == {"cam_01": 0.0, "cam_02": 0.0, "cam_03": 0.0, "cam_04": 0.0}
    refused = [line for line in said if "is not applied: its confidence" in line]
    assert len(refused) == 3 and all("the calibration's +0.000 s is kept" in line for line in refused)
    # the error line gives the offsets used their own number, and names the estimates not applied as such
    pattern = (
        r"sync: median reprojection error ([\d.]+) px with the calibration's offsets, ([\d.]+) px with those used; "
        r"the estimates not applied \(cam_02, cam_03, cam_04\) would give [\d.]+ px"
    )
    (line,) = [line for line in logged if line.startswith("sync: median")]
    match = re.fullmatch(pattern, line)
    assert match and match[1] == match[2], line  # nothing applied: what was used is the calibration's


def test_a_large_shift_needs_high_confidence() -> None:
    cameras = [SimpleNamespace(name=f"cam{c}", time_offset_s=0.0) for c in range(3)]
    estimate = SimpleNamespace(offsets_s=np.array([0.0, 0.85, 0.85]), confidence=np.array([1.0, 0.3, 0.7]), rate=60.0)
    said: list[str] = []
    assert trusted_offsets(estimate, cameras, 4.0, said.append) == pytest.approx([0.0, 0.0, 0.85])
    assert said == [
        "sync cam1: the estimated offset +0.850 s (+51.0 frames) is not applied: it moves the view by 0.850 s, over "
        "10% of the 4.0 s clip, which needs confidence 0.5 (got 0.30); the calibration's +0.000 s is kept (check "
        "it, or pass an offsets .json)"
    ]
