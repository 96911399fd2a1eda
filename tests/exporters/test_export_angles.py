"""Joint angles: zero pose and signs on hand-built poses, continuity on real mocap, CSV and report read back."""

from __future__ import annotations

import csv
from pathlib import Path

import cv2
import numpy as np
import pytest
from export_helpers import two_person_result

from platypose.exporters.angles import ANGLE_NAMES, angle_series, continue_angles, joint_angles, write_angles_csv
from platypose.exporters.export import export
from platypose.exporters.report import ankle_heights, write_report
from platypose.lifting.anatomy.hinges import HINGE_NAMES
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
    assert a["left_shoulder_plane"] == pytest.approx(90) and a["left_shoulder_elevation"] == pytest.approx(90)
    assert a["right_shoulder_elevation"] == pytest.approx(0, abs=1e-9)
    assert a["right_shoulder_rotation"] == pytest.approx(0, abs=1e-6)  # forearm forward, arm hanging
    assert a["left_elbow_flexion"] == pytest.approx(0, abs=1e-6)
    assert a["right_elbow_flexion"] == pytest.approx(90)
    assert a["left_hip_abduction"] == pytest.approx(np.degrees(0.5))
    assert a["right_hip_abduction"] == pytest.approx(0, abs=1e-9)
    inward = standing()
    inward[J["right_wrist"]] = inward[J["right_elbow"]] + [0.26, 0, 0]  # right forearm across the body
    assert angles_of(inward)["right_shoulder_rotation"] == pytest.approx(90)
    # the arm raised sideways, then forwards: plane 0 then 90, elevation the angle from hanging
    for plane, elevation in ((0, 60), (0, 120), (90, 170), (45, 90)):
        raised = standing()
        e, q = np.radians(elevation), np.radians(plane)
        direction = np.array([np.sin(e) * np.cos(q), -np.sin(e) * np.sin(q), -np.cos(e)])
        raised[J["left_elbow"]] = raised[J["left_shoulder"]] + 0.27 * direction
        raised[J["left_wrist"]] = raised[J["left_elbow"]] + 0.26 * direction
        got = angles_of(raised)
        assert got["left_shoulder_plane"] == pytest.approx(plane, abs=1e-6)
        assert got["left_shoulder_elevation"] == pytest.approx(elevation)
    lean = standing()
    tilt = np.radians(30)
    for name, height in (("spine", 0.24), ("thorax", 0.48)):
        lean[J[name]] = lean[J["pelvis"]] + height * np.array([0, -np.sin(tilt), np.cos(tilt)])
    a = angles_of(lean)
    assert a["trunk_flexion"] == pytest.approx(30) and a["pelvis_tilt"] == pytest.approx(30)
    assert a["trunk_lateral"] == pytest.approx(0, abs=1e-9)


def test_hinges_bent_backwards_read_negative():
    """Signed flexion: a knee whose shin goes forwards and an elbow whose forearm goes backwards read
    negative, as OpenSim's coordinates; the elbow's axial rotation then reads from the model's side of the turn."""
    pose = standing()
    back = np.radians(20)
    pose[J["right_ankle"]] = pose[J["right_knee"]] + 0.41 * np.array([0, -np.sin(back), -np.cos(back)])
    pose[J["left_ankle"]] = pose[J["left_knee"]] + 0.41 * np.array([0, np.sin(back), -np.cos(back)])
    pose[J["left_wrist"]] = pose[J["left_elbow"]] + 0.26 * np.array([0, np.sin(back), -np.cos(back)])
    pose[J["right_wrist"]] = pose[J["right_elbow"]] + 0.26 * np.array([0, -np.sin(back), -np.cos(back)])
    a = angles_of(pose)
    assert a["right_knee_flexion"] == pytest.approx(-20) and a["left_knee_flexion"] == pytest.approx(20)
    assert a["left_elbow_flexion"] == pytest.approx(-20) and a["right_elbow_flexion"] == pytest.approx(20)
    assert a["left_shoulder_rotation"] == pytest.approx(0, abs=1e-6)
    # the same elbow bent 90 degrees: forearm backwards is -90 (unwrapped never: it stays in (-180, 180])
    pose[J["left_wrist"]] = pose[J["left_elbow"]] + [0, 0.26, 0]
    series = continue_angles(np.stack([joint_angles(standing()), joint_angles(pose)]))
    assert series[1, ANGLE_NAMES.index("left_elbow_flexion")] == pytest.approx(-90)


@pytest.fixture(scope="module")
def result(data_dir):
    return two_person_result(data_dir)


def test_abduction_through_90_degrees_reads_no_flip():
    """An arm held out sideways at 86-91 degrees of abduction, wobbling a few degrees
    forwards and backwards, read frame by frame. The old sagittal-plane flexion jumped between +87 and -99;
    plane of elevation, elevation and rotation now move by a few degrees per frame."""
    rng = np.random.default_rng(3)
    T = 60
    elevation = np.radians(88.0 + 3.0 * np.sin(np.linspace(0, 6, T)))
    plane = np.radians(4.0 * rng.normal(size=T))
    poses = np.repeat(standing()[None], T, axis=0)
    d = np.stack([-np.sin(elevation) * np.cos(plane), -np.sin(elevation) * np.sin(plane), -np.cos(elevation)], -1)
    poses[:, J["right_elbow"]] = poses[:, J["right_shoulder"]] + 0.27 * d
    poses[:, J["right_wrist"]] = poses[:, J["right_elbow"]] + 0.26 * np.array([0, -1.0, 0])  # forearm forward
    series = continue_angles(joint_angles(poses))
    for name in ("right_shoulder_plane", "right_shoulder_elevation", "right_shoulder_rotation"):
        assert np.abs(np.diff(series[:, ANGLE_NAMES.index(name)])).max() < 20, name


def test_a_hanging_arm_holds_its_plane_and_angles_never_wrap():
    """An arm swinging forwards and backwards through hanging (walking): ISB's plane of elevation would jump
    between +90 and -90 each time; it holds while the arm hangs. A trunk turning past the range's end
    continues (unwrapped) instead of jumping by 360."""
    T = 80
    swing = np.radians(25.0 * np.sin(np.linspace(0, 4 * np.pi, T)))
    poses = np.repeat(standing()[None], T, axis=0)
    d = np.stack([0 * swing, -np.sin(swing), -np.cos(swing)], -1)
    poses[:, J["left_elbow"]] = poses[:, J["left_shoulder"]] + 0.27 * d
    poses[:, J["left_wrist"]] = poses[:, J["left_elbow"]] + 0.26 * d
    series = continue_angles(joint_angles(poses))
    assert np.abs(np.diff(series[:, ANGLE_NAMES.index("left_shoulder_plane")])).max() < 45
    raw = np.array([[170.0], [-175.0], [-160.0]]) * np.ones((1, len(ANGLE_NAMES)))
    np.testing.assert_allclose(continue_angles(raw)[:, 0], [170.0, 185.0, 200.0])


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
    values = series[0]  # no gap: the median's angles of each frame, made continuous
    np.testing.assert_allclose(values[..., 0], continue_angles(joint_angles(np.asarray(result.median[0], np.float64))))


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


def test_npz_holds_the_angles_the_csv_holds(result, tmp_path):
    """The npz stores the fit's angles (no reader re-derives them): read back by numpy, they are the CSV's rows."""
    export(result, tmp_path, "clip", formats=("npz", "angles"))
    with np.load(tmp_path / "clip.npz", allow_pickle=False) as raw:
        angles, names, columns = raw["angles"], list(raw["angle_names"]), list(raw["angle_columns"])
    assert angles.shape == (2, result.num_frames, len(ANGLE_NAMES), 4) and angles.dtype == np.float32
    assert names == list(ANGLE_NAMES) and columns == ["median", "q05", "q50", "q95"]
    with open(tmp_path / "clip_angles.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for row in rows[:: len(rows) // 97]:
        p = result.track_ids.tolist().index(int(row["person"]))
        got = angles[p, int(row["frame"]), names.index(row["angle"])]
        want = [float(row[f"{c}_deg"]) for c in columns]
        np.testing.assert_allclose(got, want, atol=5e-3)
    assert np.isfinite(angles[0]).all() and np.isfinite(angles[1, 5:]).all()


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


@pytest.mark.parametrize(
    "file, person",
    [
        ("pose2sim_cam01_pelvis_median.npy", None),
        ("pose2sim_cam01_median.npy", None),
        ("pose2sim_4views_median.npy", None),
        ("sports2d_demo_medians.npy", 0),
        ("sports2d_demo_medians.npy", 1),
    ],
)
def test_real_lifts_angles_step_only_with_the_arm(file, person):
    """Real lifts (tests/data/lifts, gaps filled): no angle of a side steps over 45 degrees between frames where
    that side's upper arm turns under 10 (the old angles stepped up to 353 degrees on sports2d); knees and elbows by
    their size (the stored lifts predate the joint limits: some of their hinges bend backwards, signed negative)."""
    from platypose.exporters.gaps import fill_frames, fill_plan

    joints = np.load(Path(__file__).parents[1] / "data" / "lifts" / file).astype(np.float64)
    joints = joints if person is None else joints[person]
    present = np.isfinite(joints).all(axis=(1, 2))
    joints = fill_frames(joints, fill_plan(present, np.arange(len(joints))), slice(None))
    series = continue_angles(joint_angles(joints))
    hinges = [ANGLE_NAMES.index(f"{name}_flexion") for name in HINGE_NAMES]
    series[:, hinges] = np.abs(series[:, hinges])  # these old lifts bend hinges backwards: a sign is no step
    steps = np.abs(np.diff(series, axis=0))
    for side in ("right", "left"):
        arm = joints[:, J[f"{side}_elbow"]] - joints[:, J[f"{side}_shoulder"]]
        arm /= np.linalg.norm(arm, axis=-1, keepdims=True)
        calm = np.degrees(np.arccos(np.clip(np.sum(arm[1:] * arm[:-1], axis=-1), -1.0, 1.0))) < 10
        columns = [k for k, name in enumerate(ANGLE_NAMES) if name.startswith(side)]
        assert steps[np.ix_(calm, columns)].max() <= 45.0, side
