"""The importers of the prior's newer training sources, on real files of each (tests/data/motion, cut short).

- CMU exponential maps (``cmu_expmap``): a whole real running clip;
- Character Creator BVH (CMU subject 5, iClone conversion): its first 60 frames;
- Poser BVH (CMU subject 60, salsa, at 0.7 scale): its first 240 frames;
- Rigify-style BVH (ReActIdle idle standing): its first 48 frames.

The converted clips in data/motion were made from the full files by tools/import_mocap_sets.py; each test
also checks that the converted clip starts with what the importer reads from the real file.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from motion_sanity import assert_plausible, facing_agrees_with_travel

from platypose.lifting.motion_io import load_motion
from platypose.lifting.skeleton import JOINT_INDEX

HERE = Path(__file__).parents[2]
MOTION = HERE / "data" / "motion"
REPO = HERE.parent


@pytest.fixture(scope="module")
def importer():
    """tools/import_mocap_sets.py as a module (the conversion that made the data/motion folders)."""
    spec = importlib.util.spec_from_file_location("import_mocap_sets", REPO / "tools" / "import_mocap_sets.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def _head_neck_m(joints: np.ndarray) -> float:
    return float(np.median(np.linalg.norm(joints[:, JOINT_INDEX["head"]] - joints[:, JOINT_INDEX["neck"]], axis=-1)))


def _starts_converted_clip(importer, motion, scale: float, converted: Path, frames: int) -> None:
    """The converted npz's first ``frames`` frames are the importer's clip, settled, scaled and resampled."""
    ours = importer.at_30fps(motion, scale)[0][:frames]
    with np.load(converted) as data:
        stored = data["joints"][:frames]
        assert float(data["fps"]) == 30.0
    np.testing.assert_allclose(stored, ours, atol=1e-5)


def test_cmu_exponential_maps_give_a_runner_running_forwards(importer):
    (motion,) = load_motion(MOTION / "cmu_expmap_running_2.txt")
    assert motion.extra["format"] == "cmu_expmap" and motion.fps == 120 and motion.num_frames == 190
    assert_plausible(motion, rigid_tol_m=1e-6)
    joints = motion.joints[1:]  # the file's first row is the skeleton's rest pose (cut by the conversion)
    assert importer.settled_segments(motion.joints, motion.fps)[0].start == 1
    speed = np.linalg.norm(np.diff(joints[:, 0, :2], axis=0), axis=-1).mean() * motion.fps
    assert 2.5 < speed < 7.0  # m/s: a run, in metres (ASF units of 1/0.45 inch)
    moved = type(motion)(joints=joints, fps=motion.fps, name=motion.name)
    assert facing_agrees_with_travel(moved) > 0.9  # left is left: the runner faces where he goes
    assert 0.04 < _head_neck_m(joints) < 0.1
    _starts_converted_clip(importer, motion, 1.0, REPO / "data/motion/cmu-expmap/train_running_2.npz", 40)


def test_character_creator_bvh_is_read_by_its_naming(importer):
    (motion,) = load_motion(MOTION / "cc_005_02_first60.bvh")
    assert motion.fps == pytest.approx(60, abs=0.01) and motion.num_frames == 60
    assert_plausible(motion, rigid_tol_m=1e-4)
    assert 0.04 < _head_neck_m(motion.joints) < 0.1  # halfway from the skull base to the eyes
    _starts_converted_clip(importer, motion, 1.0, REPO / "data/motion/cmu-iclone/005_02.npz", 28)


def test_poser_bvh_is_read_by_its_naming_and_rescaled_to_human_size(importer):
    (motion,) = load_motion(MOTION / "poser_60_01_scaled_first240.bvh")
    assert motion.fps == pytest.approx(120, abs=0.01)
    run = importer.settled_segments(motion.joints, motion.fps)[0]
    assert run.start == 3  # the clip jumps out of a rest pose in its first frames
    scale = importer.SETS["cmu-poser-salsa"].scale
    grown = type(motion)(joints=motion.joints[run] * scale, fps=motion.fps, name=motion.name)
    assert_plausible(grown, rigid_tol_m=1e-4)
    height = grown.joints[:, JOINT_INDEX["head"], 2] - grown.joints[:, [3, 6], 2].min(axis=1)
    assert 1.5 < np.median(height) < 1.8  # ankle to head centre, standing
    _starts_converted_clip(importer, motion, scale, REPO / "data/motion/cmu-poser-salsa/60_01_scaled.npz", 25)


def test_rigify_bvh_takes_the_wrist_from_the_forearms_end_site(importer):
    (motion,) = load_motion(MOTION / "rigify_001_acted_first48.bvh")
    assert motion.fps == pytest.approx(24, abs=0.01)
    joints = motion.joints
    for side in ("left", "right"):
        forearm = np.linalg.norm(
            joints[:, JOINT_INDEX[f"{side}_wrist"]] - joints[:, JOINT_INDEX[f"{side}_elbow"]], axis=-1
        )
        assert 0.18 < np.median(forearm) < 0.3 and np.ptp(forearm) < 1e-4
    assert 0.05 < _head_neck_m(joints) < 0.1  # past the skull base ("face") by half the neck
    upright = joints[:, JOINT_INDEX["head"], 2] - joints[:, JOINT_INDEX["pelvis"], 2]
    assert upright.min() > 0.5  # standing idle
    _starts_converted_clip(importer, motion, 1.0, REPO / "data/motion/reactidle/001_acted.npz", 18)


def test_repeats_of_one_trial_are_found_across_conversions(importer):
    """The same CMU trial read from two conversions is a repeat; two different trials of one runner are not."""
    (a,) = load_motion(MOTION / "cmu_expmap_running_2.txt")
    whole = importer.resample(a.joints, a.fps, 30.0)
    references = [("running_2", a.duration_s, whole)]
    assert importer.duplicates(whole.copy(), a.duration_s, references) == "running_2"
    shifted = whole[10:]  # a later part of the same run: not the same trial's length
    assert importer.duplicates(shifted, len(shifted) / 30.0, references) is None
