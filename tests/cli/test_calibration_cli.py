"""``platypose calib convert`` / ``check`` end to end on the real Pose2Sim demo, through the console entry point."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

DEMO = "video/pose2sim-balancing"


def test_convert_writes_native_json(data_dir: Path, tmp_path: Path, run_cli):
    out = tmp_path / "calib.json"
    code, stdout, _ = run_cli("calib", "convert", str(data_dir / DEMO / "calib_pose2sim.toml"), "--out", str(out))
    assert code == 0 and "4 camera(s) cam_01, cam_02, cam_03, cam_04" in stdout
    data = json.loads(out.read_text())
    assert [c["name"] for c in data["cameras"]] == ["cam_01", "cam_02", "cam_03", "cam_04"]
    assert data["cameras"][3]["K"][1][1] == 1675.204223640625 and data["cameras"][3]["size"] == [1920, 1088]


def test_convert_with_world_up_and_units(tmp_path: Path, run_cli):
    src = tmp_path / "calib.json"
    src.write_text(
        json.dumps(
            {
                "format": "platypose-calib",
                "version": 1,
                "units": "cm",
                "world_up": "y",
                "cameras": [
                    {
                        "name": "c",
                        "size": [480, 640],
                        "K": [[500, 0, 320], [0, 500, 240], [0, 0, 1]],
                        "rvec": [0, 0, 0],
                        "t": [0, 0, 300],
                    }
                ],
            }
        )
    )
    out = tmp_path / "out.json"
    code, stdout, _ = run_cli("calib", "convert", str(src), "--out", str(out))
    assert code == 0 and "units cm scaled to metres" in stdout
    cam = json.loads(out.read_text())["cameras"][0]
    assert cam["t"] == [0.0, 0.0, 3.0]
    assert np.allclose(cam["R"], [[1, 0, 0], [0, 0, 1], [0, -1, 0]])


def test_convert_video_uses_fov_prior(data_dir: Path, tmp_path: Path, run_cli):
    out = tmp_path / "demo.json"
    code, stdout, _ = run_cli("calib", "convert", str(data_dir / "video/sports2d-demo/demo.mp4"), "--out", str(out))
    assert code == 0 and "53.1 degree diagonal FOV prior" in stdout and "no extrinsics" in stdout
    cam = json.loads(out.read_text())["cameras"][0]
    assert cam["name"] == "demo" and cam["size"] == [994, 1768]
    assert (
        cam["K"][0][0] == pytest.approx(np.hypot(1768, 994)) and cam["K"][0][2] == 884.0 and cam["t"] == [0.0, 0.0, 0.0]
    )


def test_check_prints_cameras_warns_sizes_and_triangulates(data_dir: Path, run_cli):
    demo = data_dir / DEMO
    code, stdout, _ = run_cli(
        "calib",
        "check",
        str(demo / "calib_pose2sim.toml"),
        str(demo / "cam01.mp4"),
        str(demo / "cam02.mp4"),
        "--keypoints",
        str(demo / "openpose-body25b"),
        "--fps",
        "60",
    )
    assert code == 0
    assert "cam_01: 1088x1920 px, focal 1681.2/1681.1 px, at (1.460, -1.909, 1.897) m" in stdout
    assert (
        "camera cam_01 is calibrated for 1088x1920 px, cam01.mp4 is 1080x1920 px: the codec's padding to a multiple "
        "of 16, the same pixels" in stdout
    ) and "warning" not in stdout
    assert "triangulated 100 frames from 4 views" in stdout
    error = float(stdout.split("median reprojection error ")[-1].split(" px")[0])
    assert 10.0 < error < 16.0  # measured 14.0 px on our 17 joints


def test_bad_input_exits_2_with_one_line(data_dir: Path, tmp_path: Path, run_cli):
    bad = tmp_path / "bad.toml"
    bad.write_text(
        (data_dir / DEMO / "calib_pose2sim.toml").read_text().replace("fisheye = false", "fisheye = true", 1)
    )
    code, _, stderr = run_cli("calib", "convert", str(bad), "--out", str(tmp_path / "x.json"))
    assert code == 2 and stderr.strip().count("\n") == 0 and "fisheye" in stderr and str(bad) in stderr
    assert not (tmp_path / "x.json").exists()
    code, _, stderr = run_cli(
        "calib",
        "check",
        str(data_dir / DEMO / "calib_pose2sim.toml"),
        str(data_dir / DEMO / "cam01.mp4"),
        str(tmp_path / "cam07.mp4"),
    )
    assert code == 2 and "cam07.mp4 match no camera" in stderr
