"""Job discovery for ``platypose lift``: videos, views of one take, folders of takes, globs, ``--keypoints`` layouts."""

from __future__ import annotations

from pathlib import Path

import pytest

from platypose.cli.runs.jobs import check_camera_count, discover_jobs, expand_inputs, keypoints_job
from platypose.lifting.errors import InputError

TAKE = "video/pose2sim-balancing"
CAMERAS = ("cam_01", "cam_02", "cam_03", "cam_04")


def _link(target: Path, link: Path) -> Path:
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(target)
    return link


def test_videos_of_calibrated_cameras_form_one_take(data_dir) -> None:
    take = data_dir / TAKE
    (job,) = discover_jobs(expand_inputs([str(take / "cam0[12].mp4")]), CAMERAS)
    assert job.name == "pose2sim-balancing"
    assert [(v.name, v.video.name) for v in job.views] == [("cam01", "cam01.mp4"), ("cam02", "cam02.mp4")]
    # without a multi-camera calibration each video is its own input
    jobs = discover_jobs(expand_inputs([str(take / "cam0[12].mp4")]), ())
    assert [j.name for j in jobs] == ["cam01", "cam02"] and all(len(j.views) == 1 for j in jobs)


def test_more_videos_than_calibrated_cameras_are_one_error_saying_so(data_dir) -> None:
    videos = expand_inputs([str(data_dir / TAKE / "cam0*.mp4")])
    jobs = discover_jobs(videos, ("cam_01",))  # a calibration of one camera for the take of four
    with pytest.raises(InputError) as caught:
        check_camera_count(jobs, ("cam_01",), Path("one.json"))
    assert str(caught.value) == (
        "one.json: the calibration has 1 camera (cam_01), you gave 4 videos; cam02.mp4, cam03.mp4, cam04.mp4 match "
        "none of its cameras: give the calibration of every camera, or lift only the videos it calibrates"
    )
    check_camera_count(discover_jobs(videos, CAMERAS), CAMERAS, Path("calib.toml"))  # one take of four cameras
    check_camera_count(discover_jobs(videos[:1], ("cam_01",)), ("cam_01",), Path("one.json"))
    clips = [data_dir / TAKE / "cam01.mp4", data_dir / "video/sports2d-demo/demo.mp4"]  # clips of one camera
    check_camera_count(discover_jobs(clips, ("cam_01",)), ("cam_01",), Path("one.json"))


def test_folder_of_videos_and_of_takes(data_dir, tmp_path) -> None:
    take = data_dir / TAKE
    _link(take / "cam03.mp4", tmp_path / "season" / "warmup.mp4")
    for name in ("cam01.mp4", "cam02.mp4"):
        _link(take / name, tmp_path / "season" / "jump1" / name)
        _link(take / name, tmp_path / "season" / "jump2" / name)
    jobs = discover_jobs([tmp_path / "season"], CAMERAS)
    assert [(j.name, len(j.views)) for j in jobs] == [("warmup", 1), ("jump1", 2), ("jump2", 2)]
    # uncalibrated: every video is an input; equal names get distinct output folders
    names = [j.name for j in discover_jobs([tmp_path / "season"], ())]
    assert names == ["warmup", "cam01", "cam02", "cam01-2", "cam02-2"]


def test_bad_inputs_are_named(data_dir, tmp_path) -> None:
    with pytest.raises(InputError, match="glob matches nothing"):
        expand_inputs([str(tmp_path / "*.mp4")])
    with pytest.raises(InputError, match="no video found"):
        discover_jobs([tmp_path], CAMERAS)
    with pytest.raises(InputError, match="after --keypoints"):
        discover_jobs([data_dir / TAKE / "openpose-body25b" / "cam01_json" / "cam01.0000.json"], CAMERAS)


def test_pose2sim_keypoint_layout(data_dir, tmp_path) -> None:
    keypoints = data_dir / TAKE / "openpose-body25b"
    job = keypoints_job(keypoints, [], CAMERAS)
    assert job.name == "openpose-body25b"
    assert [(v.name, v.source.name, v.video.name) for v in job.views] == [
        (f"cam0{i}", f"cam0{i}_json", f"cam0{i}.mp4") for i in range(1, 5)
    ]
    single = keypoints_job(keypoints / "cam02_json", [], CAMERAS)
    assert single.name == "cam02" and single.views[0].video.name == "cam02.mp4"
    with pytest.raises(InputError, match="match none of its views"):
        keypoints_job(keypoints, [data_dir / "video/sports2d-demo/demo.mp4"], CAMERAS)
    with pytest.raises(InputError, match=r"no view for|match no camera"):
        keypoints_job(keypoints, [], ("front", "back"))


def test_per_view_keypoint_files_match_cameras(tmp_path) -> None:
    for name in ("cam01_keypoints2d.npz", "cam03_keypoints2d.npz"):  # as written by platypose detect
        (tmp_path / name).touch()
    job = keypoints_job(tmp_path, [], CAMERAS)
    assert [(v.name, v.source.name) for v in job.views] == [
        ("cam01", "cam01_keypoints2d.npz"),
        ("cam03", "cam03_keypoints2d.npz"),
    ]
    # files that do not all name cameras are one view's source, not several views
    (tmp_path / "notes.json").touch()
    assert len(keypoints_job(tmp_path, [], CAMERAS).views) == 1
