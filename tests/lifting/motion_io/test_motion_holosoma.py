"""holosoma (T, 53, 3) npy importer on the five real climbing clips."""

from __future__ import annotations

import numpy as np
import pytest
from motion_sanity import assert_plausible

from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import HOLOSOMA_MOCAP_NAMES
from platypose.lifting.motion_io import load_motion
from platypose.lifting.skeleton import JOINT_INDEX

FRAMES = {"seq_0": 2801, "seq_1": 2423, "seq_2": 3011, "seq_3": 2401, "seq_4": 2303}


@pytest.fixture(scope="module")
def clips(data_dir):
    return {p.name: load_motion(p) for p in sorted((data_dir / "motion/holosoma-climb").glob("*.npy"))}


def test_every_clip_loads_with_frames_rate_and_licence(clips):
    assert len(clips) == 5
    for name, motions in clips.items():
        (m,) = motions
        key = next(k for k in FRAMES if k in name)
        assert m.num_frames == FRAMES[key]
        assert m.fps == 120.0
        assert m.licence == "Apache-2.0"
        assert "holosoma" in m.source


def test_clips_are_plausible_people(clips):
    for (m,) in clips.values():
        assert_plausible(m, rigid_tol_m=0.012)


def test_joints_are_the_named_markers(data_dir, clips):
    path = data_dir / "motion/holosoma-climb/mocap_climb_seq_0_joint_positions_f900-3700.npy"
    raw = np.load(path)
    (m,) = clips[path.name]
    names = list(HOLOSOMA_MOCAP_NAMES)
    np.testing.assert_allclose(m.joints[:, JOINT_INDEX["left_knee"]], raw[:, names.index("LeftLeg")], atol=1e-6)
    np.testing.assert_allclose(m.joints[:, JOINT_INDEX["neck"]], raw[:, names.index("Head")], atol=1e-6)
    pelvis = 0.5 * (raw[:, names.index("LeftUpLeg")] + raw[:, names.index("RightUpLeg")])
    np.testing.assert_allclose(m.joints[:, JOINT_INDEX["pelvis"]], pelvis, atol=1e-6)
    # Left really is on the left: the feet point forward (ankle -> toe), and up x forward is left.
    forward = raw[:, names.index("LeftToeBase")] - raw[:, names.index("LeftFoot")]
    left = np.cross([0.0, 0.0, 1.0], forward)
    hips = m.joints[:, JOINT_INDEX["left_hip"]] - m.joints[:, JOINT_INDEX["right_hip"]]
    assert np.mean(np.sum(hips * left, axis=-1) > 0) > 0.9


def test_hand_speed_is_plausible_at_120_fps(clips):
    (m,) = clips["mocap_climb_seq_0_joint_positions_f900-3700.npy"]
    wrists = m.joints[:, [JOINT_INDEX["left_wrist"], JOINT_INDEX["right_wrist"]]]
    speed = np.linalg.norm(np.diff(wrists, axis=0), axis=-1) * m.fps
    assert 1.0 < np.percentile(speed, 99.9) < 3.0


def test_fps_override_and_bad_files(tmp_path, data_dir):
    src = data_dir / "motion/holosoma-climb/mocap_climb_seq_4_joint_positions_f0-2303.npy"
    assert load_motion(src, fps=60)[0].fps == 60
    wrong = tmp_path / "wrong.npy"
    np.save(wrong, np.zeros((10, 17, 3)))
    with pytest.raises(InputError, match="wrong.npy.*53"):
        load_motion(wrong)
    corrupt = tmp_path / "corrupt.npy"
    corrupt.write_bytes(src.read_bytes()[:300])
    with pytest.raises(InputError, match="corrupt.npy"):
        load_motion(corrupt)
    unknown = tmp_path / "clip.xyz"
    unknown.write_text("1 2 3")
    with pytest.raises(InputError, match="clip.xyz.*unknown motion format"):
        load_motion(unknown)
