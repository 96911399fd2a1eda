"""BVH importer: the real mocapbank file, and BVH files written here whose poses are worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest
from motion_sanity import assert_plausible

from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import LIMB_JOINTS, MOTIONBUILDER_LIMBS
from platypose.lifting.motion_io import load_motion
from platypose.lifting.motion_io.bvh import local_transforms, parse_bvh
from platypose.lifting.motion_io.kinematics import forward_kinematics, y_up_to_z_up
from platypose.lifting.skeleton import JOINT_INDEX

INCH = 0.0254

# A MotionBuilder-named skeleton in inches; Head has no End Site (a Jaw child instead).
HIERARCHY = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
  JOINT LeftUpLeg
  {
    OFFSET 4 -2 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LeftLeg
    {
      OFFSET 0 -17 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT LeftFoot
      {
        OFFSET 0 -17 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 -3 5
        }
      }
    }
  }
  JOINT RightUpLeg
  {
    OFFSET -4 -2 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT RightLeg
    {
      OFFSET 0 -17 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT RightFoot
      {
        OFFSET 0 -17 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 -3 5
        }
      }
    }
  }
  JOINT Spine
  {
    OFFSET 0 4 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Spine1
    {
      OFFSET 0 8 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT Neck
      {
        OFFSET 0 8 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT Head
        {
          OFFSET 0 4 0
          CHANNELS 3 Zrotation Xrotation Yrotation
          JOINT Jaw
          {
            OFFSET 0 -1 2
            CHANNELS 3 Zrotation Xrotation Yrotation
            End Site
            {
              OFFSET 0 0 1
            }
          }
        }
      }
      JOINT LeftArm
      {
        OFFSET 6 7 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT LeftForeArm
        {
          OFFSET 11 0 0
          CHANNELS 3 Zrotation Xrotation Yrotation
          JOINT LeftHand
          {
            OFFSET 10 0 0
            CHANNELS 3 Zrotation Xrotation Yrotation
            End Site
            {
              OFFSET 3 0 0
            }
          }
        }
      }
      JOINT RightArm
      {
        OFFSET -6 7 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT RightForeArm
        {
          OFFSET -11 0 0
          CHANNELS 3 Zrotation Xrotation Yrotation
          JOINT RightHand
          {
            OFFSET -10 0 0
            CHANNELS 3 Zrotation Xrotation Yrotation
            End Site
            {
              OFFSET -3 0 0
            }
          }
        }
      }
    }
  }
}
"""
JOINTS = [line.split()[1] for line in HIERARCHY.splitlines() if line.strip().startswith(("ROOT", "JOINT"))]


def write_bvh(
    path, frames: list[dict[str, list[float]]], hierarchy: str = HIERARCHY, frame_time: float = 1 / 60
) -> None:
    """Write a BVH; each frame maps joint names to channel values (missing joints are zero)."""
    rows = []
    for frame in frames:
        values = []
        for name in JOINTS:
            values += frame.get(name, [0.0] * (6 if name == "Hips" else 3))
        rows.append(" ".join(f"{v:g}" for v in values))
    path.write_text(
        hierarchy + f"MOTION\nFrames: {len(frames)}\nFrame Time: {frame_time:.6f}\n" + "\n".join(rows) + "\n"
    )


def z_up(bvh_point, scale=INCH):
    """Hand conversion of a BVH (Y-up) point to our Z-up metres: (x, y, z) -> (x, -z, y)."""
    x, y, z = bvh_point
    return np.array([x, -z, y]) * scale


FRAMES = [
    {"Hips": [10, 35, 20, 0, 0, 0]},
    # Root yawed 90 deg about Y; left knee bent 90 deg about X (channel order Z X Y).
    {"Hips": [10, 35, 20, 0, 90, 0], "LeftLeg": [0, 90, 0]},
    # Left knee Z=90 then X=90: composes as Rz @ Rx, so the shin points along -Z (not +X as Rx @ Rz would).
    {"Hips": [10, 35, 20, 0, 0, 0], "LeftLeg": [90, 90, 0]},
]


@pytest.fixture()
def written(tmp_path):
    path = tmp_path / "handmade.bvh"
    write_bvh(path, FRAMES)
    return path


def test_handmade_poses_match_hand_computation(written):
    (m,) = load_motion(written)
    assert m.extra["unit"] == "inch" and m.fps == 60.0 and m.num_frames == 3
    knee, ankle = JOINT_INDEX["left_knee"], JOINT_INDEX["left_ankle"]
    np.testing.assert_allclose(m.joints[0, knee], z_up((14, 16, 20)), atol=1e-9)
    np.testing.assert_allclose(m.joints[0, JOINT_INDEX["left_hip"]], z_up((14, 33, 20)), atol=1e-9)
    # Frame 1: Ry(90) takes (x, y, z) to (z, y, -x): hip offset (4,-2,0) -> (0,-2,-4); shin -> (-17, 0, 0).
    np.testing.assert_allclose(m.joints[1, knee], z_up((10, 16, 16)), atol=1e-9)
    np.testing.assert_allclose(m.joints[1, ankle], z_up((-7, 16, 16)), atol=1e-9)
    np.testing.assert_allclose(m.joints[2, ankle], z_up((14, 16, 3)), atol=1e-9)
    # Neck is the Head joint (skull base); with no End Site the head centre is 0.5 neck lengths beyond it.
    np.testing.assert_allclose(m.joints[0, JOINT_INDEX["neck"]], z_up((10, 59, 20)), atol=1e-9)
    np.testing.assert_allclose(m.joints[0, JOINT_INDEX["head"]], z_up((10, 61, 20)), atol=1e-9)
    np.testing.assert_allclose(m.joints[0, JOINT_INDEX["pelvis"]], z_up((10, 33, 20)), atol=1e-9)


def test_units_detected_or_given(tmp_path, written):
    (inches,) = load_motion(written)
    metres_text = HIERARCHY
    for line in {ln for ln in HIERARCHY.splitlines() if "OFFSET" in ln}:
        scaled = " ".join(f"{float(v) * INCH:.6f}" for v in line.split()[1:])
        metres_text = metres_text.replace(line + "\n", line.split("OFFSET")[0] + "OFFSET " + scaled + "\n")
    frames = [{**f, "Hips": [v * INCH for v in f["Hips"][:3]] + f["Hips"][3:]} for f in FRAMES]
    path = tmp_path / "metres.bvh"
    write_bvh(path, frames, hierarchy=metres_text)
    (metres,) = load_motion(path)
    assert metres.extra["unit"] == "m"
    np.testing.assert_allclose(metres.joints, inches.joints, atol=1e-5)
    (given,) = load_motion(written, scale=0.01)
    np.testing.assert_allclose(given.joints, inches.joints * 0.01 / INCH, atol=1e-9)


def test_name_map_for_unknown_naming(tmp_path):
    rename = {v: f"j_{k}" for k, v in MOTIONBUILDER_LIMBS.items()} | {"Head": "skull"}
    text = HIERARCHY
    for old, new in sorted(rename.items(), key=lambda kv: -len(kv[0])):
        text = text.replace(f" {old}\n", f" {new}\n")
    path = tmp_path / "renamed.bvh"
    write_bvh(path, FRAMES, hierarchy=text)
    with pytest.raises(InputError, match="renamed.bvh.*no known naming"):
        load_motion(path)
    name_map = {k: f"j_{k}" for k in LIMB_JOINTS} | {"neck": "skull"}
    (m,) = load_motion(path, name_map=name_map)
    np.testing.assert_allclose(m.joints[1, JOINT_INDEX["left_ankle"]], z_up((-7, 16, 16)), atol=1e-9)
    with pytest.raises(InputError, match="renamed.bvh.*lacks.*neck"):
        load_motion(path, name_map={k: f"j_{k}" for k in LIMB_JOINTS})


def test_real_mocapbank_file(data_dir):
    (m,) = load_motion(data_dir / "motion/mocapbank/test_mocapbank.bvh")
    assert m.num_frames == 455 and m.fps == 30.0 and m.licence == "MIT"
    assert m.extra["unit"] == "cm"
    assert_plausible(m, rigid_tol_m=1e-6, min_head_rise_m=0.3)
    # Head End Site present: head centre is halfway between the Head joint (neck) and the head top.
    height = m.joints[:, JOINT_INDEX["head"], 2].max() - m.joints[:, [3, 6], 2].min()
    assert 1.3 < height < 1.9
    # Left is left: the feet point forward (ankle -> toe End Site), and up x forward is left.
    clip = parse_bvh((data_dir / "motion/mocapbank/test_mocapbank.bvh").read_text())
    points = y_up_to_z_up(forward_kinematics(clip.parents, *local_transforms(clip)))
    forward = points[:, clip.names.index("LeftAnkle_end")] - points[:, clip.names.index("LeftAnkle")]
    hips = m.joints[:, JOINT_INDEX["left_hip"]] - m.joints[:, JOINT_INDEX["right_hip"]]
    assert np.mean(np.sum(hips * np.cross([0.0, 0.0, 1.0], forward), axis=-1) > 0) > 0.9


def test_broken_bvh_files(tmp_path, written):
    text = written.read_text()
    cut = tmp_path / "cut.bvh"
    cut.write_text(text[: len(text) - 20])
    with pytest.raises(InputError, match="cut.bvh.*expected 3 frames"):
        load_motion(cut)
    braces = tmp_path / "braces.bvh"
    braces.write_text(text.replace("HIERARCHY", "HIERARCHY\n{", 1))
    with pytest.raises(InputError, match="braces.bvh"):
        load_motion(braces)
    empty = tmp_path / "empty.bvh"
    empty.write_text("")
    with pytest.raises(InputError, match="empty.bvh.*HIERARCHY"):
        load_motion(empty)


def test_reads_back_our_own_exported_bvh(tmp_path, data_dir):
    from platypose.exporters.bvh import write_bvh

    (climb,) = load_motion(data_dir / "motion/holosoma-climb/mocap_climb_seq_1_joint_positions_f0-2422.npy")
    path = tmp_path / "ours.bvh"
    fit = write_bvh(climb.joints[:120], climb.fps, path)
    (back,) = load_motion(path)
    assert back.extra["unit"] == "cm" and back.fps == pytest.approx(120.0)
    error = np.linalg.norm(back.joints - climb.joints[:120], axis=-1)
    assert error.max() <= fit.max_m + 1e-3


def test_namespaced_joint_names_are_recognised(tmp_path, written):
    text = HIERARCHY
    for name in JOINTS:
        text = text.replace(f" {name}\n", f" mixamorig:{name}\n")
    path = tmp_path / "mixamo.bvh"
    write_bvh(path, FRAMES, hierarchy=text)
    np.testing.assert_array_equal(load_motion(path)[0].joints, load_motion(written)[0].joints)


def test_z_up_file_is_not_rotated(tmp_path, written):
    text = HIERARCHY
    for line in {ln for ln in HIERARCHY.splitlines() if "OFFSET" in ln}:
        x, y, z = (float(v) for v in line.split()[1:])
        text = text.replace(line + "\n", line.split("OFFSET")[0] + f"OFFSET {x:g} {-z:g} {y:g}\n")
    path = tmp_path / "zup.bvh"
    write_bvh(path, [{"Hips": [10, -20, 35, 0, 0, 0]}], hierarchy=text)
    (m,) = load_motion(path)
    assert m.extra["up"] == "z" and m.extra["unit"] == "inch"
    np.testing.assert_allclose(m.joints[0], load_motion(written)[0].joints[0], atol=1e-9)
