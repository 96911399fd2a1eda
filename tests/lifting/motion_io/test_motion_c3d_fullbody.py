"""C3D importer on real Plug-in Gait full-body trials: all 17 joints, sane lengths, on their floor.

The tennis serve has bare markers only; the overground walk has the model's
lower-body joint centres (LFEP, LFEO, LTIO) and bare upper-body markers.

The hip, knee and ankle recipes of bare Plug-in Gait markers are fitted to the
Plug-in Gait joint centres of the gaitalytics treadmill trial; the test checks
them there against those centres (the trial holds both).
"""

from __future__ import annotations

import numpy as np
import pytest
from motion_sanity import assert_plausible, facing_agrees_with_travel

from platypose.lifting.joint_maps import C3D_MARKER_RECIPES
from platypose.lifting.motion_io import load_motion
from platypose.lifting.motion_io.c3d import read_markers
from platypose.lifting.skeleton import JOINT_INDEX, JOINT_NAMES


@pytest.fixture(scope="module")
def tennis(data_dir):
    return load_motion(data_dir / "motion/kineticstoolkit-tennis/kinematics_tennis_serve.c3d")[0]


def test_all_joints_from_plug_in_gait_markers(tennis):
    assert (tennis.num_frames, tennis.fps) == (1092, 50.0)
    assert tennis.extra["missing_joints"] == []
    assert np.isfinite(tennis.joints).all()
    assert tennis.extra["joint_sources"]["right_wrist"] == "RWRA+RWRB"
    assert tennis.extra["joint_sources"]["head"] == "LFHD+RFHD+LBHD+RBHD"
    assert tennis.licence.startswith("Apache-2.0")


def test_metres_upright_on_its_floor(tennis):
    j = tennis.joints
    lowest_ankle = np.minimum(j[:, JOINT_INDEX["left_ankle"], 2], j[:, JOINT_INDEX["right_ankle"], 2])
    assert 0.02 < np.median(lowest_ankle) < 0.12  # ankle centres a few cm over the lab floor z = 0
    assert np.percentile(lowest_ankle, 1) > -0.01
    height = j[:, JOINT_INDEX["head"], 2] - j[:, JOINT_INDEX["pelvis"], 2]
    assert 0.55 < np.median(height) < 0.8


def test_adult_limbs_upright(tennis):
    assert_plausible(tennis, rigid_tol_m=0.03, min_head_rise_m=0.55)


def test_fitted_leg_recipes_against_plug_in_gait_centres(data_dir):
    labels, markers, scale, _ = read_markers(data_dir / "motion/gait-c3d/gaitalytics_treadmill_events.c3d")
    markers = markers * scale
    index = {label: i for i, label in enumerate(labels)}
    for joint, centre in (("hip", "FEP"), ("knee", "FEO"), ("ankle", "TIO")):
        for side, s in (("right", "R"), ("left", "L")):
            recipe = C3D_MARKER_RECIPES[f"{side}_{joint}"][-1]
            estimate = sum(w * markers[:, index[name]] for name, w in recipe.items())
            error = np.linalg.norm(estimate - markers[:, index[f"{s}{centre}"]], axis=-1)
            assert np.nanmedian(error) < 0.025, (joint, side)


def test_recipes_weights_sum_to_one():
    for joint in JOINT_NAMES:
        for weights in C3D_MARKER_RECIPES[joint]:
            assert sum(weights.values()) == pytest.approx(1.0)


def test_overground_walk_mixes_model_centres_and_markers(data_dir):
    (walk,) = load_motion(data_dir / "motion/gaitalytics-fullbody/gaitalytics_walk_fullbody.c3d")
    assert (walk.num_frames, walk.fps) == (337, 100.0)
    assert walk.extra["missing_joints"] == []
    sources = walk.extra["joint_sources"]
    assert (sources["left_hip"], sources["spine"], sources["right_elbow"]) == ("LFEP", "LFEP+RFEP+LSHO+RSHO", "RELB")
    assert walk.licence.startswith("MIT")
    assert_plausible(walk, rigid_tol_m=0.03, min_head_rise_m=0.55)
    assert facing_agrees_with_travel(walk) > 0.8
    ankles = walk.joints[:, [JOINT_INDEX["left_ankle"], JOINT_INDEX["right_ankle"]], 2]
    assert 0.03 < ankles.min() < 0.1
