"""Flags that mean something: a human body passes, a body no human has is flagged, in one sentence everywhere."""

from __future__ import annotations

import numpy as np
from standing_body import standing

from platypose.lifting.checks.body import angles_out_of_range, bone_lengths_out_of_range, joint_flexions
from platypose.lifting.checks.flags import flag_text, person_lines
from platypose.lifting.checks.plausibility import body_plausibility
from platypose.lifting.skeleton import JOINT_INDEX


def test_a_standing_person_is_human():
    pose = standing()
    angles = joint_flexions(pose)
    assert np.allclose(angles["right knee"], 10.0) and np.allclose(angles["right knee hyperextension"], -10.0)
    assert angles_out_of_range(pose) == {} and bone_lengths_out_of_range(pose) == {}


def test_a_knee_bent_backwards_and_a_long_shin_are_flagged_with_their_figures():
    backwards = standing(knee_bend_deg=-60.0)  # the shin swings forwards: the knee bends the wrong way
    out = angles_out_of_range(backwards)
    assert set(out) == {"right knee hyperextension", "left knee hyperextension"}
    assert out["right knee hyperextension"]["share"] == 1.0 and out["right knee hyperextension"]["max_deg"] == 60.0
    long_shin = standing()
    long_shin[:, JOINT_INDEX["left_ankle"], 2] -= 0.4  # a 0.83 m shin, and twice its mirror image
    assert list(bone_lengths_out_of_range(long_shin)) == ["left knee-left ankle", "right knee-right ankle"]
    report = body_plausibility({"flags": ["under floor"], "under_floor_share": 0.2, "one_view": False}, long_shin)
    assert report["flags"] == ["under floor", "bone lengths"]
    assert body_plausibility({"flags": [], "one_view": True}, long_shin)["flags"] == []  # one view: the prior's guess
    text = flag_text(report)
    assert text.startswith("under floor (20% of hypothesis-frames more than 3 cm under it); bone lengths (left knee")
    assert person_lines([{**report, "flag_text": text}], [4]) == [f"person 4: flagged: {text}"]


def test_a_few_odd_frames_are_not_a_flag():
    pose = standing(frames=100)
    pose[:3, JOINT_INDEX["right_ankle"]] = pose[:3, JOINT_INDEX["right_hip"]] + [0.0, -0.01, 0.0]  # knee folded flat
    assert angles_out_of_range(pose) == {}
    pose[:10, JOINT_INDEX["right_ankle"]] = pose[:10, JOINT_INDEX["right_hip"]] + [0.0, -0.01, 0.0]
    assert list(angles_out_of_range(pose)) == ["right knee"]


def test_on_the_floor_and_unflagged_says_nothing_a_roof_is_said():
    on_floor = {"flags": [], "support": [{"first_frame": 0, "last_frame": 99, "height_m": 0.02}]}
    roof = {"flags": [], "support": [{"first_frame": 0, "last_frame": 122, "height_m": 1.92}]}
    assert person_lines([on_floor, roof], [0, 1]) == ["person 1: stands 1.92 m above the floor in frames 0-122"]


def test_a_real_one_view_forearm_that_swings_in_a_frame_is_flagged_with_its_frames():
    """The balancing take lifted from cam01 alone (tests/data/lifts, 60 fps): its right forearm's plane swings about
    120 degrees around the upper arm in frames 80-86, which the signed elbow flexion shows as a jump; all four views
    of the same take turn no hinge faster than a body can."""
    from pathlib import Path

    from platypose.lifting.checks.body import HINGE_SPEED_DEG_S, hinge_jumps

    lifts = Path(__file__).parents[2] / "data" / "lifts"
    assert hinge_jumps(np.load(lifts / "pose2sim_4views_median.npy"), fps=60.0) == {}
    one_view = np.load(lifts / "pose2sim_cam01_median.npy")
    jumps = hinge_jumps(one_view, fps=60.0)
    assert 85 in jumps["right elbow"]["frames"] and jumps["right elbow"]["max_deg_per_s"] > 5 * HINGE_SPEED_DEG_S
    assert set(jumps) <= {"right elbow", "left elbow"}  # its knees turn as a body turns them
    report = body_plausibility({"flags": [], "one_view": True}, one_view, fps=60.0)
    assert report["flags"] == ["hinge jumps"] and report["hinge_jumps"] == jumps
    assert "right elbow " in flag_text(report) and "in frames 39, 58, 85" in flag_text(report)
    assert body_plausibility({"flags": [], "one_view": True}, one_view, fps=6.0)["flags"] == []  # a tenth as fast
