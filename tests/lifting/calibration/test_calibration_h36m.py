"""Human3.6M camera JSON (VideoPose3D's published parameters): conventions checked against its own projection."""

from __future__ import annotations

import json
import re
from pathlib import Path

import cv2
import numpy as np
import pytest

from platypose.lifting.calibration import load_calibration
from platypose.lifting.camera import project
from platypose.lifting.errors import InputError

H36M = Path(__file__).parents[2] / "data" / "calib" / "h36m_cameras.json"


def _qrot_inverse(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors (N, 3) by the inverse of quaternion q = (w, x, y, z), by the cross-product formula."""
    w, qv = q[0], -q[1:] / np.linalg.norm(q)
    w = w / np.linalg.norm(q)
    uv = np.cross(qv, v)
    return v + 2 * (w * uv + np.cross(qv, uv))


def _videopose3d_projection(points_mm: np.ndarray, intr: dict, extr: dict) -> np.ndarray:
    """Human3.6M's own model as VideoPose3D writes it: world mm -> pixels (N, 2)."""
    cam = _qrot_inverse(np.array(extr["orientation"]), points_mm - np.array(extr["translation"]))
    xx = cam[:, :2] / cam[:, 2:]
    r2 = (xx**2).sum(-1, keepdims=True)
    k, p = np.array(intr["radial_distortion"]), np.array(intr["tangential_distortion"])
    radial = 1 + k[0] * r2 + k[1] * r2**2 + k[2] * r2**3
    tan = (p * xx).sum(-1, keepdims=True)
    xxx = xx * (radial + tan) + p * r2
    return np.array(intr["focal_length"]) * xxx + np.array(intr["center"])


def test_s1_cameras_and_projection():
    raw = json.loads(H36M.read_text())
    cal = load_calibration(H36M, subject="S1")
    assert cal.names == ("54138969", "55011271", "58860488", "60457274")
    assert cal.meta["subject"] == "S1" and "units mm scaled to metres (x0.001)" in cal.meta["conversions"]
    rng = np.random.default_rng(4)
    points = rng.uniform([-1.0, -1.0, 0.0], [1.0, 1.0, 1.9], size=(300, 3))  # the capture area, metres
    for cam, intr, extr, note in zip(cal.cameras, raw["intrinsics"], raw["extrinsics"]["S1"], cal.meta["conversions"]):
        assert cam.size == (intr["res_h"], intr["res_w"])
        assert np.allclose(cam.center, np.array(extr["translation"]) / 1000)
        assert 1.4 < cam.center[2] < 1.7 and cam.R[2] @ -cam.center > 0  # 1.5 m up, looking at the centre
        expected = _videopose3d_projection(points * 1000, intr, extr)
        max_px = float(re.search(r"max difference ([0-9.]+) px", note).group(1))
        assert 0 < max_px < 0.5
        assert np.abs(project(points, cam) - expected).max() < max_px + 1e-3
        opencv = cv2.projectPoints(points, cv2.Rodrigues(cam.R)[0], cam.t, cam.K, cam.dist)[0].reshape(-1, 2)
        assert np.abs(project(points, cam) - opencv).max() < 1e-6


def test_subject_choice():
    with pytest.raises(InputError, match="give subject, one with extrinsics: S1, S9"):
        load_calibration(H36M)
    with pytest.raises(InputError, match="subject 'S2' has no extrinsics"):
        load_calibration(H36M, subject="S2")
    s9 = load_calibration(H36M, subject="S9")
    assert np.allclose(s9.cameras[0].center, [2.04445849609375, 4.9351171875, 1.4812275390625])


def test_broken_h36m(tmp_path: Path):
    raw = json.loads(H36M.read_text())
    del raw["intrinsics"][1]["focal_length"]
    path = tmp_path / "cams.json"
    path.write_text(json.dumps(raw))
    with pytest.raises(InputError, match="intrinsics entry 1 needs fields"):
        load_calibration(path, subject="S1")
    raw = json.loads(H36M.read_text())
    raw["extrinsics"]["S1"] = raw["extrinsics"]["S1"][:3]
    path.write_text(json.dumps(raw))
    with pytest.raises(InputError, match="S1 lists 3 cameras, intrinsics list 4"):
        load_calibration(path, subject="S1")
    path.write_text(json.dumps({"cameras": []}))
    with pytest.raises(InputError, match="neither a platypose-calib file nor Human3.6M"):
        load_calibration(path)
