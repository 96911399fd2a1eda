"""DeepMimic humanoid importer (FK over humanoid.urdf) on the 15 real clips."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from motion_sanity import assert_plausible, facing_agrees_with_travel

from platypose.lifting.errors import InputError
from platypose.lifting.motion_io import load_motion
from platypose.lifting.motion_io.deepmimic import read_urdf
from platypose.lifting.skeleton import JOINT_INDEX

# Clips where the person stands or moves on their feet (not crawling, rolling, getting up, cartwheeling).
UPRIGHT = ("walk", "run", "jump", "kick", "punch", "dance_a", "dance_b", "spin", "spinkick")


@pytest.fixture(scope="module")
def clips(data_dir):
    folder = data_dir / "motion/deepmimic"
    return {p.stem.removeprefix("humanoid3d_"): load_motion(p)[0] for p in sorted(folder.glob("*.txt"))}


def test_all_clips_load_with_rate_from_frame_durations(clips, data_dir):
    assert len(clips) == 15
    assert clips["walk"].fps == pytest.approx(30.0, rel=1e-3)
    assert clips["jump"].fps == pytest.approx(60.0, rel=1e-3)
    assert clips["backflip"].fps == pytest.approx(16.0, rel=1e-3)
    raw = json.loads((data_dir / "motion/deepmimic/humanoid3d_walk.txt").read_text())["Frames"]
    assert clips["walk"].num_frames == len(raw)
    assert all(m.licence.startswith("zlib") for m in clips.values())


def test_clips_are_plausible_people(clips):
    # Limbs are rigid up to the roll clip's one doubled frame step, filled by linear interpolation (0.3 mm).
    for name, m in clips.items():
        assert_plausible(m, rigid_tol_m=1e-3, min_head_rise_m=0.4 if name in UPRIGHT else 0.03)


def test_root_is_pelvis_of_file_and_z_up(clips, data_dir):
    frames = np.array(json.loads((data_dir / "motion/deepmimic/humanoid3d_walk.txt").read_text())["Frames"])
    pelvis = clips["walk"].joints[:, JOINT_INDEX["pelvis"]]
    # The hips sit symmetrically about the root link, so the pelvis is the root: Y-up (x, y, z) -> (x, -z, y).
    np.testing.assert_allclose(pelvis, np.stack([frames[:, 1], -frames[:, 3], frames[:, 2]], axis=1), atol=1e-9)


def test_walk_faces_where_it_goes_and_feet_touch_ground(clips):
    walk = clips["walk"]
    assert facing_agrees_with_travel(walk) > 0.9
    speed = np.linalg.norm(walk.joints[-1, 0, :2] - walk.joints[0, 0, :2]) / walk.duration_s
    assert 0.8 < speed < 2.0
    ankles = walk.joints[:, [JOINT_INDEX["left_ankle"], JOINT_INDEX["right_ankle"]], 2]
    assert 0.03 < ankles.min() < 0.15


def test_urdf_is_scaled_to_metres(data_dir):
    skeleton = read_urdf(data_dir / "motion/deepmimic/humanoid.urdf")
    knee = skeleton.names.index("left_knee")
    assert np.linalg.norm(skeleton.offsets[knee]) == pytest.approx(0.25 * 1.686184)


def test_missing_urdf_and_corrupt_clip(tmp_path, data_dir):
    clip = tmp_path / "walk.txt"
    shutil.copy(data_dir / "motion/deepmimic/humanoid3d_walk.txt", clip)
    with pytest.raises(InputError, match="walk.txt.*humanoid.urdf"):
        load_motion(clip)
    assert load_motion(clip, urdf=data_dir / "motion/deepmimic/humanoid.urdf")[0].num_frames == 39
    shutil.copy(data_dir / "motion/deepmimic/humanoid.urdf", tmp_path)
    clip.write_text(clip.read_text()[:2000])
    with pytest.raises(InputError, match="walk.txt"):
        load_motion(clip)
    short = tmp_path / "short.json"
    short.write_text(json.dumps({"Frames": [[0.03] + [0.0] * 20, [0.0] + [0.0] * 20]}))
    with pytest.raises(InputError, match="short.json.*21 values"):
        load_motion(short)
