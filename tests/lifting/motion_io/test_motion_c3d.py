"""C3D importer on the two real lower-body trials: what exists is mapped, what does not is NaN and listed."""

from __future__ import annotations

import numpy as np
import pytest

from platypose.lifting.errors import InputError
from platypose.lifting.motion_io import load_motion
from platypose.lifting.skeleton import JOINT_INDEX, JOINT_NAMES

UPPER = [
    "spine",
    "thorax",
    "neck",
    "head",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
]


@pytest.fixture(scope="module")
def trials(data_dir):
    folder = data_dir / "motion/gait-c3d"
    return {
        "gait": load_motion(folder / "gaitalytics_treadmill_events.c3d")[0],
        "jump": load_motion(folder / "biomdp_vicon_CMJ_kinem_kinet_emg.c3d")[0],
    }


def test_frames_rates_and_missing_joints(trials):
    gait, jump = trials["gait"], trials["jump"]
    assert (gait.num_frames, gait.fps) == (1206, 100.0)
    assert (jump.num_frames, jump.fps) == (1600, 200.0)
    assert gait.extra["missing_joints"] == UPPER
    assert jump.extra["missing_joints"] == ["left_knee", "left_ankle", *UPPER]
    assert jump.extra["joint_sources"]["right_knee"] == "RKJC"
    assert gait.extra["joint_sources"]["left_ankle"] == "LTIO"
    for m in trials.values():
        assert m.licence.startswith("MIT")
        missing = [JOINT_INDEX[j] for j in m.extra["missing_joints"]]
        present = [j for j in range(len(JOINT_NAMES)) if j not in missing]
        assert np.isnan(m.joints[:, missing]).all()
        assert np.isfinite(m.joints[:, present]).mean() > 0.99


@pytest.mark.parametrize("name", ["gait", "jump"])
def test_legs_plausible_and_upright(trials, name):
    m = trials[name]
    j = m.joints
    for side in ("right", "left") if name == "gait" else ("right",):
        hip, knee, ankle = (JOINT_INDEX[f"{side}_{p}"] for p in ("hip", "knee", "ankle"))
        thigh = np.linalg.norm(j[:, knee] - j[:, hip], axis=-1)
        shank = np.linalg.norm(j[:, ankle] - j[:, knee], axis=-1)
        assert 0.35 < np.nanmedian(thigh) < 0.5 and 0.35 < np.nanmedian(shank) < 0.5
        assert np.nanstd(thigh) < 0.015 and np.nanstd(shank) < 0.015
        assert np.nanmean(j[:, hip, 2]) > np.nanmean(j[:, knee, 2]) > np.nanmean(j[:, ankle, 2]) > 0
    assert 0.75 < np.nanmedian(j[:, JOINT_INDEX["pelvis"], 2]) < 1.1
    width = np.nanmedian(np.linalg.norm(j[:, JOINT_INDEX["left_hip"]] - j[:, JOINT_INDEX["right_hip"]], axis=-1))
    assert 0.1 < width < 0.2


def test_gait_walks_in_place_on_treadmill_with_alternating_feet(trials):
    j = trials["gait"].joints
    left, right = j[:, JOINT_INDEX["left_ankle"]], j[:, JOINT_INDEX["right_ankle"]]
    forward = np.cross(j[:, JOINT_INDEX["left_hip"]] - j[:, JOINT_INDEX["right_hip"]], [0, 0, 1]).mean(axis=0)
    forward /= np.linalg.norm(forward)
    lead = (left - right) @ forward
    assert lead.max() > 0.3 and lead.min() < -0.3  # each foot leads in turn by a step length
    assert np.ptp(j[:, JOINT_INDEX["pelvis"]] @ forward) < 0.3  # treadmill: the pelvis stays put
    # Left is left: "forward" from (left hip - right hip) x up must be where the feet swing to; in stance
    # (most of the time) the belt carries them backwards, so the median foot velocity points backwards.
    velocity = np.diff(left, axis=0) @ forward
    assert np.median(velocity) < 0 < np.percentile(velocity, 95)


def test_truncated_and_junk_c3d(tmp_path, data_dir):
    src = (data_dir / "motion/gait-c3d/gaitalytics_treadmill_events.c3d").read_bytes()
    cut = tmp_path / "cut.c3d"
    cut.write_bytes(src[:3_000_000])
    with pytest.raises(InputError, match="cut.c3d.*truncated"):
        load_motion(cut)
    junk = tmp_path / "junk.c3d"
    junk.write_bytes(b"hello, not a c3d")
    with pytest.raises(InputError, match="junk.c3d"):
        load_motion(junk)
