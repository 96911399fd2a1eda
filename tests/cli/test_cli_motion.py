"""``platypose motion info`` end to end on real files, through the console entry point."""

from __future__ import annotations

import json


def test_info_text_on_folder(data_dir, run_cli):
    code, out, _ = run_cli(
        "motion",
        "info",
        str(data_dir / "motion/cmu-asf-amc"),
        str(data_dir / "motion/gait-c3d/biomdp_vicon_CMJ_kinem_kinet_emg.c3d"),
    )
    assert code == 0
    assert "test [asf_amc]: 2751 frames at 120 fps = 22.93 s" in out
    assert "licence: MIT package; CMU mocap terms" in out
    assert "missing joints (NaN): left_knee, left_ankle, spine" in out
    assert "right_hip-right_knee 0.427" in out
    assert "2 clip(s)" in out


def test_info_json_and_fps_override(data_dir, run_cli):
    code, out, err = run_cli(
        "motion",
        "info",
        "--json",
        "--fps",
        "60",
        str(data_dir / "motion/holosoma-climb/mocap_climb_seq_4_joint_positions_f0-2303.npy"),
    )
    assert code == 0 and "1 clip(s)" in err
    (summary,) = [json.loads(line) for line in out.splitlines()]
    assert summary["fps"] == 60 and summary["frames"] == 2303 and summary["licence"] == "Apache-2.0"
    assert 1.3 < summary["ankle_to_head_m"] < 1.8
    assert 0.35 < summary["bone_lengths_m"]["left_hip-left_knee"] < 0.5


def test_info_bad_file_exits_2_with_one_line(tmp_path, run_cli):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT\n")
    code, out, err = run_cli("motion", "info", str(bad))
    assert code == 2 and err.count("\n") == 1 and "bad.bvh" in err


def test_info_name_map_file(tmp_path, data_dir, run_cli):
    mapping = tmp_path / "map.json"
    mapping.write_text("[1, 2]")
    code, _, err = run_cli(
        "motion", "info", "--name-map", str(mapping), str(data_dir / "motion/mocapbank/test_mocapbank.bvh")
    )
    assert code == 2 and "map.json" in err
