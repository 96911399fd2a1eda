"""``platypose detect`` through the console entry: real video and OpenPose folder in, our npz/CSV out."""

from __future__ import annotations

import csv
import re

import numpy as np
import pytest

POSE2SIM = "video/pose2sim-balancing"


def test_detect_video_writes_npz_and_csv(run_cli, data_dir, tmp_path) -> None:
    video = str(data_dir / POSE2SIM / "cam02.mp4")
    args = ("detect", video, "--out", str(tmp_path), "--stride", "25", "--max-frames", "4", "--threads", "1", "--quiet")
    reference = str(data_dir / POSE2SIM / "openpose-body25b/cam02_json")
    code, out, err = run_cli(*args, "--compare", reference)
    assert code == 0, err
    assert "4 frames" in out and "ms/frame" in out
    compared = re.search(r"\(person 0, 4/100 frames\): median ([0-9.]+) px", out)
    assert compared and float(compared.group(1)) < 30  # the athlete, against OpenPose
    folder = tmp_path / "cam02"
    with np.load(folder / "cam02_keypoints2d.npz") as data:
        keypoints = data["keypoints2d"]
        np.testing.assert_allclose(data["frame_times"], np.array([0, 25, 50, 75]) / 60.0)
    assert keypoints.shape[0] == 1 and keypoints.shape[2:] == (4, 17, 3)
    # the man on the force plate: pelvis in the lower middle of the portrait frame in every frame
    main_person = int(np.argmax((keypoints[0, ..., 2] > 0).sum(axis=(1, 2))))
    pelvis = keypoints[0, main_person, :, 0, :2]
    assert np.all((pelvis[:, 0] > 300) & (pelvis[:, 0] < 800) & (pelvis[:, 1] > 500) & (pelvis[:, 1] < 1200))
    with open(folder / "cam02_keypoints2d.csv", newline="") as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == keypoints.shape[1] * 4 * 17
    code, out, _ = run_cli(*args)
    assert code == 0 and "read from the cache" in out


def test_detect_converts_an_openpose_folder(run_cli, data_dir, tmp_path) -> None:
    folder = str(data_dir / POSE2SIM / "openpose-body25b/cam03_json")
    code, out, err = run_cli("detect", folder, "--out", str(tmp_path), "--persons", "largest")
    assert code == 0, err
    with np.load(tmp_path / "cam03" / "cam03_keypoints2d.npz") as data:
        assert data["keypoints2d"].shape == (1, 1, 100, 17, 3)
        assert data["image_size"].tolist() == [1920, 1088]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("missing.mp4",), "missing.mp4: video file not found"),
        (("VIDEO", "--persons", "tallest"), "--persons must be"),
        (("VIDEO", "--detector-format", "nonsense"), "unknown --detector-format 'nonsense'"),
    ],
)
def test_detect_errors_are_one_line_exit_2(run_cli, data_dir, tmp_path, args, message) -> None:
    args = tuple(str(data_dir / POSE2SIM / "cam01.mp4") if a == "VIDEO" else a for a in args)
    code, _, err = run_cli("detect", *args, "--out", str(tmp_path), "--max-frames", "1", "--quiet")
    assert code == 2
    assert message in err and err.count("\n") == 1


def test_detect_views_with_calibration_share_ids(run_cli, data_dir, tmp_path) -> None:
    folder = data_dir / POSE2SIM / "openpose-body25b"
    views = [str(folder / f"cam0{i}_json") for i in (1, 2, 3)]
    calib = str(data_dir / POSE2SIM / "calib_pose2sim.toml")
    code, out, err = run_cli("detect", *views, "--cams", calib, "--out", str(tmp_path))
    assert code == 0, err
    assert "person 1: not seen in this view" in out  # the person in the background is not in cam03
    seen = {}
    for i in (1, 2, 3):
        with np.load(tmp_path / f"cam0{i}" / f"cam0{i}_keypoints2d.npz") as data:
            assert data["track_ids"].tolist() == [0, 1]
            seen[i] = (data["keypoints2d"][0, ..., 2] > 0).any(axis=2).sum(axis=1).tolist()
    assert seen == {1: [100, 100], 2: [100, 100], 3: [100, 0]}
