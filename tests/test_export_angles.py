"""Joint angles: zero pose and signs on hand-built poses, continuity on real mocap, CSV and report read back."""

from __future__ import annotations

import csv

import cv2
import numpy as np
import pytest
from export_helpers import two_person_result

from platypose.exporters.angles import ANGLE_NAMES, angle_series, joint_angles, write_angles_csv
from platypose.exporters.report import ankle_heights, write_report
from platypose.lifting.skeleton import JOINT_INDEX as J


def standing() -> np.ndarray:
    """An upright person facing -y (left side +x), arms hanging, (17, 3) metres."""
    p = np.zeros((17, 3))
    for name, xyz in {
        "pelvis": (0, 0, 1.0),
        "right_hip": (-0.085, 0, 1.0),
        "right_knee": (-0.085, 0, 0.58),
        "right_ankle": (-0.085, 0, 0.17),
        "left_hip": (0.085, 0, 1.0),
        "left_knee": (0.085, 0, 0.58),
        "left_ankle": (0.085, 0, 0.17),
        "spine": (0, 0, 1.24),
        "thorax": (0, 0, 1.48),
        "neck": (0, 0, 1.6),
        "head": (0, 0, 1.78),
        "left_shoulder": (0.18, 0, 1.48),
        "left_elbow": (0.18, 0, 1.21),
        "left_wrist": (0.18, 0, 0.95),
        "right_shoulder": (-0.18, 0, 1.48),
        "right_elbow": (-0.18, 0, 1.21),
        "right_wrist": (-0.18, 0, 0.95),
    }.items():
        p[J[name]] = xyz
    return p


def angles_of(pose: np.ndarray) -> dict[str, float]:
    return dict(zip(ANGLE_NAMES, joint_angles(pose[None])[0]))


def test_zero_pose_reads_zero():
    assert np.abs(joint_angles(standing()[None])).max() < 1e-9


def test_signs_and_sides():
    pose = standing()
    pose[J["right_ankle"]] = pose[J["right_knee"]] + [0, 0.41, 0]  # shin back: right knee bent 90
    pose[J["left_elbow"]] = pose[J["left_shoulder"]] + [0, -0.27, 0]  # left arm forward
    pose[J["left_wrist"]] = pose[J["left_elbow"]] + [0, -0.26, 0]  # ... straight
    pose[J["right_wrist"]] = pose[J["right_elbow"]] + [0, -0.26, 0]  # right forearm forward: elbow 90
    pose[J["left_knee"]] = pose[J["left_hip"]] + 0.42 * np.array([np.sin(0.5), 0, -np.cos(0.5)])  # abducted
    pose[J["left_ankle"]] = pose[J["left_knee"]] + 0.41 * np.array([np.sin(0.5), 0, -np.cos(0.5)])
    a = angles_of(pose)
    assert a["right_knee_flexion"] == pytest.approx(90)
    assert a["left_knee_flexion"] == pytest.approx(0, abs=1e-9)
    assert a["left_shoulder_flexion"] == pytest.approx(90)
    assert a["right_shoulder_flexion"] == pytest.approx(0, abs=1e-9)
    assert a["left_elbow_flexion"] == pytest.approx(0, abs=1e-6)
    assert a["right_elbow_flexion"] == pytest.approx(90)
    assert a["left_hip_abduction"] == pytest.approx(np.degrees(0.5))
    assert a["right_hip_abduction"] == pytest.approx(0, abs=1e-9)
    # an arm raised overhead and past it stays on one branch (no wrap at 180)
    for degrees, expected in ((170, 170), (200, 200)):
        up = standing()
        r = np.radians(degrees)
        up[J["left_elbow"]] = up[J["left_shoulder"]] + 0.27 * np.array([0, -np.sin(r), -np.cos(r)])
        assert angles_of(up)["left_shoulder_flexion"] == pytest.approx(expected)
    lean = standing()
    tilt = np.radians(30)
    for name, height in (("spine", 0.24), ("thorax", 0.48)):
        lean[J[name]] = lean[J["pelvis"]] + height * np.array([0, -np.sin(tilt), np.cos(tilt)])
    a = angles_of(lean)
    assert a["trunk_flexion"] == pytest.approx(30) and a["pelvis_tilt"] == pytest.approx(30)
    assert a["trunk_lateral"] == pytest.approx(0, abs=1e-9)


@pytest.fixture(scope="module")
def result(data_dir):
    return two_person_result(data_dir)


def test_series_are_continuous_bands_ordered_and_absent_frames_held(result):
    series = angle_series(result)
    assert sorted(series) == [0, 1]
    for p, values in series.items():
        on = result.present()[p]
        assert np.isfinite(values).all()
        first = np.flatnonzero(on)[0]
        np.testing.assert_array_equal(values[:first], np.broadcast_to(values[first], values[:first].shape))
        v = values[on]
        assert (v[..., 1] <= v[..., 2] + 1e-9).all() and (v[..., 2] <= v[..., 3] + 1e-9).all()
        # real climbing at 120 fps: no angle of the median moves more than a few degrees per frame
        assert np.abs(np.diff(v[..., 0], axis=0)).max() < 15
        np.testing.assert_allclose(v[..., 0], joint_angles(np.asarray(result.median[p][on], np.float64)))


def test_csv_reads_back(result, tmp_path):
    series = angle_series(result)
    path = write_angles_csv(result, series, tmp_path / "clip_angles.csv")
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == [
        "person",
        "frame",
        "time_s",
        "angle",
        "median_deg",
        "q05_deg",
        "q50_deg",
        "q95_deg",
        "filled",
    ]
    assert len(rows) == result.present().size * len(ANGLE_NAMES)
    row = next(r for r in rows if r["person"] == "7" and r["frame"] == "12" and r["angle"] == "left_knee_flexion")
    want = series[1][12, ANGLE_NAMES.index("left_knee_flexion")]
    got = [float(row[k]) for k in ("median_deg", "q05_deg", "q50_deg", "q95_deg")]
    np.testing.assert_allclose(got, want, atol=5e-4)
    assert float(row["time_s"]) == result.frame_times[12]
    held = {r["filled"] for r in rows if r["person"] == "7" and int(r["frame"]) < 5}
    assert held == {"1"} and {r["filled"] for r in rows if r["person"] == "0"} == {"0"}


def test_report_ankle_heights_stand_on_the_lifts_floor():
    """With a floor the report's ankle heights are above it (a roof stays 2 m up); without one, above the lowest."""
    ankles = np.array([[[0.0, 5.0, 2.1], [0.1, 5.0, 2.3]], [[1.0, 4.0, 0.1], [1.0, 4.2, np.nan]]])
    level = {"normal": [0.0, 0.0, 1.0], "offset_m": 0.0, "source": "calibration"}
    heights, label = ankle_heights(ankles, level)
    assert np.allclose(heights[0], [2.1, 2.3]) and label == "cm above the floor (calibration)"
    tilted = {"normal": [0.0, -np.sin(0.1), np.cos(0.1)], "offset_m": 1.5, "source": "estimated"}
    heights, label = ankle_heights(ankles, tilted)
    assert heights[1, 0] == pytest.approx(-4.0 * np.sin(0.1) + 0.1 * np.cos(0.1) + 1.5) and "estimated" in label
    heights, label = ankle_heights(ankles, None)
    assert np.allclose(heights[0], [2.0, 2.2]) and np.nanmin(heights) == 0.0 and label == "cm above the lowest ankle"


def test_report_picture(result, tmp_path):
    series = angle_series(result)
    path = write_report(result, series, "clip", tmp_path / "clip_report.png")
    image = cv2.imread(str(path))
    assert image.shape[1] == 1800 and image.shape[0] > 2 * 300  # two person rows
    assert image.std() > 20  # drawn, not blank
    # the bands and lines are in colour (matplotlib's tab colours), not just axes
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    assert ((hsv[..., 1] > 100) & (hsv[..., 2] > 100)).mean() > 0.01
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clip_report.png"]
