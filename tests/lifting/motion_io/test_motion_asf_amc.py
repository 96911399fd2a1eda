"""ASF/AMC (CMU) importer on the real CMU trial, plus broken-file cases."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from motion_sanity import assert_plausible, facing_agrees_with_travel

from platypose.lifting.errors import InputError
from platypose.lifting.motion_io import load_motion
from platypose.lifting.motion_io.asf_amc import pose_points, read_amc, read_asf
from platypose.lifting.skeleton import JOINT_INDEX


@pytest.fixture(scope="module")
def folder(data_dir):
    return data_dir / "motion/cmu-asf-amc"


@pytest.fixture(scope="module")
def trial(folder):
    (m,) = load_motion(folder / "test.amc")
    return m


def test_trial_frames_rate_licence(trial, folder):
    frames = sum(1 for line in (folder / "test.amc").read_text().splitlines() if line.strip().isdigit())
    assert trial.num_frames == frames > 2700
    assert trial.fps == 120.0
    assert "CMU" in trial.licence


def test_trial_is_plausible_walking_person(trial):
    assert_plausible(trial, rigid_tol_m=1e-6, min_head_rise_m=0.5)
    assert facing_agrees_with_travel(trial) > 0.8
    ankles = trial.joints[:, [JOINT_INDEX["left_ankle"], JOINT_INDEX["right_ankle"]], 2]
    assert 0.04 < ankles.min() < 0.15


def test_units_are_inches_over_length(folder, trial):
    skeleton = read_asf(folder / "test.asf")
    assert skeleton.metres_per_unit == pytest.approx(0.0254 / 0.45)
    femur = skeleton.bones["lfemur"].length * skeleton.metres_per_unit
    thigh = np.linalg.norm(
        trial.joints[:, JOINT_INDEX["left_knee"]] - trial.joints[:, JOINT_INDEX["left_hip"]], axis=-1
    )
    np.testing.assert_allclose(thigh, femur, atol=1e-6)


def test_rest_pose_puts_bones_along_their_directions(folder):
    skeleton = read_asf(folder / "test.asf")
    rest = {name: np.zeros((1, 6 if name == "root" else len(b.dof))) for name, b in skeleton.bones.items()}
    rest["root"] = np.zeros((1, 6))
    names, points = pose_points(skeleton, rest)
    tibia = points[0, names.index("ltibia")] - points[0, names.index("lfemur")]
    bone = skeleton.bones["ltibia"]
    np.testing.assert_allclose(tibia, bone.length * bone.direction * skeleton.metres_per_unit, atol=1e-12)


def test_broken_and_missing_files(tmp_path, folder):
    amc = tmp_path / "walk.amc"
    shutil.copy(folder / "test.amc", amc)
    with pytest.raises(InputError, match="walk.amc.*asf"):
        load_motion(amc)
    assert load_motion(amc, asf=folder / "test.asf")[0].licence == "unknown"
    lines = (folder / "test.amc").read_text().splitlines()
    amc.write_text("\n".join(lines[:200] + [lines[200].replace(lines[200].split()[-1], "x1")] + lines[201:400]))
    shutil.copy(folder / "test.asf", tmp_path / "walk.asf")
    with pytest.raises(InputError, match="walk.amc"):
        load_motion(amc)
    amc.write_text("\n".join(lines[:300]))  # cut mid-frame: the last frame lacks bones
    with pytest.raises(InputError, match="walk.amc.*missing"):
        load_motion(amc)
    (tmp_path / "walk.asf").write_text(":version 1.10\n:units\n  length 0.45\n")
    with pytest.raises(InputError, match="walk.asf.*no :root"):
        load_motion(amc)
    assert read_amc(folder / "test.amc")["lradius"].shape[1] == 1


def test_second_cmu_subject_kick_is_plausible_on_its_floor(data_dir):
    """CMU subject 11 trial 01 (fairmotion's test data): another subject's ASF, a run-up and a soccer kick."""
    (kick,) = load_motion(data_dir / "motion/cmu-11-01/11_01.amc")
    assert (kick.num_frames, kick.fps) == (597, 120.0)
    assert "CMU" in kick.licence and kick.licence.startswith("BSD")
    assert_plausible(kick, rigid_tol_m=1e-6, min_head_rise_m=0.5)
    assert facing_agrees_with_travel(kick) > 0.8
    ankles = kick.joints[:, [JOINT_INDEX["left_ankle"], JOINT_INDEX["right_ankle"]], 2]
    assert 0.05 < ankles.min() < 0.12
