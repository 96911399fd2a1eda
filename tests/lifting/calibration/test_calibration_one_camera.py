"""A one-camera calibration is never silently used for another camera's view."""

from __future__ import annotations

import json
import shutil

import pytest

from platypose.lifting.calibration import load_calibration
from platypose.lifting.calibration.matching import match_views
from platypose.lifting.errors import InputError

TAKE = "video/pose2sim-balancing"


def test_numbered_cameras_must_match(data_dir):
    names = load_calibration(data_dir / TAKE / "calib_pose2sim.toml").names
    assert names[0] == "cam_01"
    with pytest.raises(
        InputError, match=r"view 'cam02_json' is another camera than the calibration's only camera 'cam_01'"
    ):
        match_views(["cam_01"], ["cam02_json"])
    assert match_views(["cam_01"], ["cam01.mp4"]) == {"cam_01": "cam01.mp4"}
    assert match_views(["demo"], ["my_clip.mp4"]) == {"demo": "my_clip.mp4"}  # a free name still pairs


def test_lift_with_another_cameras_calibration_fails_naming_both(run_cli, data_dir, tmp_path):
    full = tmp_path / "full.json"
    assert run_cli("calib", "convert", data_dir / TAKE / "calib_pose2sim.toml", "--out", full)[0] == 0
    content = json.loads(full.read_text())
    content["cameras"] = [c for c in content["cameras"] if c["name"] == "cam_01"]
    only = tmp_path / "only_cam_01.json"
    only.write_text(json.dumps(content))
    keypoints = tmp_path / "cam02_json"
    keypoints.mkdir()
    for path in sorted((data_dir / TAKE / "openpose-body25b/cam02_json").glob("*.json"))[:4]:
        shutil.copy(path, keypoints / path.name)
    code, _, err = run_cli(
        "lift",
        "--keypoints",
        keypoints,
        "--cams",
        only,
        "--fps",
        "60",
        "--image-size",
        "1920x1088",
        "--out",
        tmp_path / "o",
    )
    assert code != 0 and "cam02" in err and "cam_01" in err and "another camera" in err
    assert not (tmp_path / "o" / "cam02" / "cam02.npz").exists()
