"""BVH export read back by an independent parser (PyPI ``bvh``) and forward kinematics written here."""

from __future__ import annotations

import numpy as np
import pytest
from bvh import Bvh
from export_helpers import climb_joints, largest_bone_turn

from platypose.exporters.bvh import write_bvh
from platypose.lifting.skeleton import JOINT_NAMES, bone_lengths


def _axis_rotation(axis: str, degrees: np.ndarray) -> np.ndarray:
    """Elementary rotations (T, 3, 3) about x, y or z."""
    a = np.radians(degrees)
    c, s, one, zero = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    rows = {
        "X": [[one, zero, zero], [zero, c, -s], [zero, s, c]],
        "Y": [[c, zero, s], [zero, one, zero], [-s, zero, c]],
        "Z": [[c, -s, zero], [s, c, zero], [zero, zero, one]],
    }[axis]
    return np.stack([np.stack(r, -1) for r in rows], -2)


def parse_positions(path) -> tuple[dict[str, np.ndarray], Bvh]:
    """Joint positions (T, 3) per joint name in the file's own axes and units, by FK over its channels."""
    mocap = Bvh(path.read_text())
    frames = np.array(mocap.frames, dtype=np.float64)
    rotations: dict[str, np.ndarray] = {}
    positions: dict[str, np.ndarray] = {}
    for name in mocap.get_joints_names():
        start = mocap.get_joint_channels_index(name)
        channels = mocap.joint_channels(name)
        values = {ch: frames[:, start + i] for i, ch in enumerate(channels)}
        local = np.broadcast_to(np.eye(3), (len(frames), 3, 3))
        for ch in channels:  # channel order = multiplication order
            if ch.endswith("rotation"):
                local = local @ _axis_rotation(ch[0], values[ch])
        offset = np.array(mocap.joint_offset(name))
        parent = mocap.joint_parent(name)
        if parent is None:
            translation = np.stack([values.get(f"{a}position", 0 * frames[:, 0]) for a in "XYZ"], -1)
            positions[name], rotations[name] = translation + offset, local
        else:
            positions[name] = positions[parent.name] + rotations[parent.name] @ offset
            rotations[name] = rotations[parent.name] @ local
    return positions, mocap


def blender_world(positions: dict[str, np.ndarray]) -> np.ndarray:
    """Blender's default BVH import (forward -Z, up Y, centimetres to metres): (x, y, z) -> (x, -z, y) / 100."""
    p = np.stack([positions[n] for n in JOINT_NAMES], axis=1)
    return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1) / 100.0


@pytest.fixture(scope="module")
def climb(data_dir):
    return climb_joints(data_dir, 600)


def test_bvh_structure_and_stated_fit_error(climb, tmp_path):
    joints, fps = climb
    fit = write_bvh(joints, fps, tmp_path / "clip.bvh")
    positions, mocap = parse_positions(tmp_path / "clip.bvh")
    assert mocap.get_joints_names() == list(JOINT_NAMES)
    assert mocap.nframes == len(joints) and mocap.frame_time == pytest.approx(1 / fps, abs=1e-8)
    root_channels = ["Xposition", "Yposition", "Zposition", "Yrotation", "Xrotation", "Zrotation"]
    assert mocap.joint_channels("pelvis") == root_channels
    assert mocap.joint_channels("left_elbow") == ["Zrotation", "Xrotation", "Yrotation"]
    assert mocap.joint_channels("right_knee") == ["Zrotation", "Yrotation", "Xrotation"]
    text = (tmp_path / "clip.bvh").read_text()
    assert text.count("End Site") == 5
    error = np.linalg.norm(blender_world(positions) - joints, axis=-1)
    # the file holds exactly what the writer says: the stated error is the independently measured one
    assert fit.mean_m == pytest.approx(error.mean(), abs=1e-6) and fit.max_m == pytest.approx(error.max(), abs=1e-6)
    assert fit.mean_m < 0.006 and fit.max_m < 0.04
    # a rigid skeleton: every bone has one length in every frame of the file
    world = blender_world(positions)
    lengths = bone_lengths(world)
    assert np.ptp(lengths, axis=0).max() < 1e-5
    # the head points exactly where the positions' head points
    assert fit.head_deg < 0.01
    head = world[:, JOINT_NAMES.index("head")] - world[:, JOINT_NAMES.index("neck")]
    seen = joints[:, JOINT_NAMES.index("head")] - joints[:, JOINT_NAMES.index("neck")]
    cos = np.sum(head * seen, -1) / np.linalg.norm(head, axis=-1) / np.linalg.norm(seen, axis=-1)
    assert cos.min() > 1 - 1e-8


def test_bvh_rotations_are_continuous(climb, tmp_path):
    """No roll pops or Euler wraps: every channel and every joint's rotation changes a little per frame."""
    joints, fps = climb
    fit = write_bvh(joints, fps, tmp_path / "clip.bvh")
    mocap = Bvh((tmp_path / "clip.bvh").read_text())
    channels = np.array(mocap.frames, dtype=np.float64)[:, 3:]
    # the real climb at 120 fps turns no bone by more than a few degrees per frame
    data_step = largest_bone_turn(joints)
    assert data_step < 8.0
    assert np.abs(np.diff(channels, axis=0)).max() < 4 * data_step
    assert fit.step_deg < 2 * data_step
    # a straight leg whose knee wobbles 2 mm sideways every frame (its plane flips: noise) keeps its roll
    noisy = joints.copy()
    hip, knee, ankle = (JOINT_NAMES.index(n) for n in ("left_hip", "left_knee", "left_ankle"))
    down = noisy[:, ankle] - noisy[:, hip]
    down /= np.linalg.norm(down, axis=-1, keepdims=True)
    side = np.cross(down, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side, axis=-1, keepdims=True)
    wobble = 0.002 * (-1.0) ** np.arange(len(noisy))[:, None] * side
    noisy[:, knee] = noisy[:, hip] + 0.42 * down + wobble
    noisy[:, ankle] = noisy[:, hip] + 0.83 * down
    fit = write_bvh(noisy, fps, tmp_path / "noisy.bvh")
    assert fit.step_deg < 2 * data_step and fit.max_m < 0.04


def test_high_step_keeps_the_thigh_roll(data_dir, tmp_path):
    """Climbing: the left thigh flexed far past horizontal (a high step) turns smoothly, no roll flip."""
    joints, fps = climb_joints(data_dir, 2050)
    joints = joints[1900:]  # the climber's highest left step of this clip (frame 1963)
    fit = write_bvh(joints, fps, tmp_path / "step.bvh")
    assert fit.step_deg < 2 * largest_bone_turn(joints)


def test_clean_motion_round_trips_under_a_millimetre(climb, tmp_path):
    joints, fps = climb
    write_bvh(joints, fps, tmp_path / "first.bvh")
    clean = blender_world(parse_positions(tmp_path / "first.bvh")[0])  # rigid skeleton, real movement
    fit = write_bvh(clean, fps, tmp_path / "clean.bvh")
    again = blender_world(parse_positions(tmp_path / "clean.bvh")[0])
    assert np.linalg.norm(again - clean, axis=-1).max() < 1e-3
    assert fit.max_m < 1e-3


def test_bvh_imports_upright_and_facing_forward(climb, tmp_path):
    joints, fps = climb
    write_bvh(joints, fps, tmp_path / "clip.bvh")
    positions, mocap = parse_positions(tmp_path / "clip.bvh")
    # rest pose (offsets only) in Blender's frame: stands up +Z, left side +X, faces -Y (Blender's front)
    rest = {}
    for name in mocap.get_joints_names():
        parent = mocap.joint_parent(name)
        rest[name] = np.array(mocap.joint_offset(name)) + (rest[parent.name] if parent else 0)
    rest_world = blender_world({k: v[None] for k, v in rest.items()})[0]
    idx = JOINT_NAMES.index
    assert rest_world[idx("head"), 2] > rest_world[idx("pelvis"), 2] > rest_world[idx("left_ankle"), 2]
    assert rest_world[idx("left_hip"), 0] > 0 > rest_world[idx("right_hip"), 0]
    left = rest_world[idx("left_hip")] - rest_world[idx("right_hip")]
    facing = np.cross(left, [0.0, 0.0, 1.0])  # a person's front is left x up
    assert facing / np.linalg.norm(facing) @ [0.0, -1.0, 0.0] > 0.999
    # the motion imported into Blender is upright (Z) and faces where the real motion faces
    world = blender_world(positions)
    assert (world[:, idx("head"), 2] > world[:, idx("pelvis"), 2]).mean() > 0.95

    def facing_of(j):
        lr = j[:, idx("left_hip")] - j[:, idx("right_hip")]
        f = np.cross(lr, [0.0, 0.0, 1.0])
        return f / np.linalg.norm(f, axis=-1, keepdims=True)

    assert (np.sum(facing_of(world) * facing_of(joints), axis=-1) > 0.999).all()


def test_absent_frames_follow_the_gap_rule(climb, tmp_path):
    """Absent frames at the start hold the first present pose; inside, the joints glide linearly in time from
    the last present frame to the next (exporters.gaps), so the root never jumps."""
    joints, fps = climb
    gappy = joints[:40].copy()
    gappy[:3] = np.nan
    gappy[20:25] = np.nan
    fit = write_bvh(gappy, fps, tmp_path / "gap.bvh")
    world = blender_world(parse_positions(tmp_path / "gap.bvh")[0])
    assert len(world) == 40 and np.isfinite(world).all()
    np.testing.assert_allclose(world[0], world[3], atol=1e-9)
    weights = (np.arange(20, 25) - 19) / 6.0
    glide = gappy[19, 0] + weights[:, None] * (gappy[25, 0] - gappy[19, 0])
    np.testing.assert_allclose(world[20:25, 0], glide, atol=1e-5)
    assert fit.mean_m < 0.01
    with pytest.raises(ValueError, match="absent throughout"):
        write_bvh(np.full((5, 17, 3), np.nan), fps, tmp_path / "none.bvh")
    assert not (tmp_path / "none.bvh").exists()


def test_platypose_motion_importer_reads_the_bvh_back(climb, tmp_path):
    from platypose.lifting.motion_io import load_motion

    joints, fps = climb
    write_bvh(joints[:300], fps, tmp_path / "clip.bvh")
    names = {n: n for n in JOINT_NAMES if n not in ("pelvis", "spine", "thorax")}
    motion = load_motion(tmp_path / "clip.bvh", name_map=names)[0]
    assert motion.extra["unit"] == "cm" and motion.extra["up"] == "y" and motion.fps == pytest.approx(fps)
    assert np.linalg.norm(motion.joints - joints[:300], axis=-1).mean() < 0.002
