"""The views of one take: sync offsets are bounded and views that barely move or are short are warned about, views
at different frame rates are refused, swapped cameras are warned about (views judged by the persons they see
well), and calibration names matching no video are one error."""

from __future__ import annotations

import pytest

from platypose.lifting.errors import InputError

TAKE = "video/pose2sim-balancing"


@pytest.fixture(scope="module")
def take_views(data_dir):
    """The bundled take's cameras, tracks (OpenPose, 60 fps) and each view's main person."""
    from platypose.detectors.sources.openpose import read_openpose_folder
    from platypose.lifting.calibration import load_calibration

    cal = load_calibration(data_dir / TAKE / "calib_pose2sim.toml")
    folders = [data_dir / TAKE / "openpose-body25b" / f"cam0{i}_json" for i in range(1, 5)]
    tracks = [read_openpose_folder(f, fps=60, image_size=c.size) for f, c in zip(folders, cal.cameras)]
    return cal.cameras, tracks


def _sync(choice, cameras, keypoints, times):
    from platypose.lifting.sync.choice import synchronise

    warnings: list[str] = []
    synced = synchronise(choice, keypoints, times, cameras, lambda _: None, warnings.append)
    return synced, warnings


def test_sync_offsets_bounded_and_still_or_short_views_warned(run_cli, data_dir, take_views, tmp_path) -> None:
    import numpy as np

    cameras, tracks = take_views
    keypoints, times = [t.keypoints for t in tracks], [t.frame_times for t in tracks]
    for offsets, needle in (
        ({"cam01": 0, "cam02": 1e4, "cam03": 0, "cam04": 0}, "shares no time with"),
        ({"cam01": 0, "cam02": 1e6, "cam03": 0, "cam04": 0}, "at most 86400"),
        ({"cam01": 0, "cam02": 10**400, "cam03": 0, "cam04": 0}, "finite numbers of seconds"),
    ):
        path = tmp_path / "offsets.json"
        path.write_text(__import__("json").dumps(offsets))
        with pytest.raises(InputError, match=needle):
            _sync(offsets, cameras, keypoints, times)
        code, _, err = run_cli(
            "calib", "check", str(data_dir / TAKE / "calib_pose2sim.toml"), "--keypoints",
            str(data_dir / TAKE / "openpose-body25b"), "--fps", "60", "--sync", str(path),
        )  # fmt: skip
        assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, err
    rng = np.random.default_rng(0)
    still = np.repeat(keypoints[1][:1], len(keypoints[1]), axis=0)
    still[..., :2] += rng.normal(0.0, 1.0, still[..., :2].shape)  # a frozen view: detector jitter only
    synced, warnings = _sync("auto", cameras, [keypoints[0], still, *keypoints[2:]], times)
    assert synced.confidence[1] == 0.0 and any("cam_02: the person barely moves" in w for w in warnings), warnings
    _, warnings = _sync("auto", cameras, keypoints, times)
    assert not [w for w in warnings if "barely moves" in w or "s of frames" in w]  # the real take moves for 1.7 s
    _, warnings = _sync("auto", cameras, [k[:60] for k in keypoints], [t[:60] for t in times])
    assert any("only 1.0 s of frames" in w for w in warnings), warnings
    broken = tmp_path / "broken.json"
    broken.write_text("{oops")
    with pytest.raises(InputError, match="not valid JSON"):
        _sync(str(broken), cameras[:1], keypoints[:1], times[:1])


def test_views_at_different_frame_rates_are_refused(data_dir, take_views) -> None:
    from platypose.detectors.persons.take import take_keypoints
    from platypose.detectors.sources.openpose import read_openpose_folder

    cameras, tracks = take_views
    slow = read_openpose_folder(data_dir / TAKE / "openpose-body25b/cam02_json", fps=30, image_size=cameras[1].size)
    assert take_keypoints(tracks[:2], cameras[:2])[0].shape[0] == 2
    with pytest.raises(InputError, match=r"different frame rates \(60, 30 fps\)"):
        take_keypoints([tracks[0], slow], cameras[:2], source="take")


def test_swapped_cameras_warned_and_views_judged_by_persons_seen_well(take_views) -> None:
    import numpy as np

    from platypose.detectors.persons.take import take_keypoints
    from platypose.detectors.persons.view_agreement import disagreeing_views
    from platypose.lifting.tracks.persons import reprojection_report
    from platypose.lifting.triangulation import triangulate

    cameras, tracks = take_views
    names = [c.name for c in cameras]
    keypoints, _, _ = take_keypoints(tracks, cameras)
    assert disagreeing_views(keypoints, names) is None  # the real rig
    swapped, _, _ = take_keypoints([tracks[2], tracks[1], tracks[0], tracks[3]], cameras)
    warning = disagreeing_views(swapped, names)
    assert warning and "cam_01 (0%)" in warning and "cam_03 (0%)" in warning and "swapped" in warning, warning
    # the correct rig, plus a far person cam_02 alone sees in 7 of 100 frames, 300 px off wherever it is lifted
    points = triangulate(keypoints[..., :2], keypoints[..., 2], cameras).transpose(1, 0, 2, 3)  # (P, T, 17, 3)
    extra = np.zeros(keypoints.shape[:2] + (1, 17, 3))
    extra[1, :7, 0] = keypoints[1, :7, 0]
    extra[1, :7, 0, :, 0] += 300.0
    median = np.concatenate([points, points[:1]])  # (P + 1, T, 17, 3)
    report, warnings = reprojection_report(median, np.concatenate([keypoints, extra], axis=2), cameras)
    assert report["cam_02"] < 20 and not [w for w in warnings if "cam_02" in w], (report, warnings)


def test_keypoints_swapped_in_pairs_are_one_line_saying_the_calibration_does_not_fit(
    run_cli, data_dir, tmp_path, prior_file
):
    """The take's keypoint folders swapped in pairs (cam01 with cam04, cam02 with cam03): each pair triangulates
    with itself, so no view stands alone, but the lift fits no view; one line says the calibration does not fit."""
    folder = tmp_path / "kp"
    folder.mkdir()
    for ours, theirs in (("cam01", "cam04"), ("cam02", "cam03"), ("cam03", "cam02"), ("cam04", "cam01")):
        (folder / f"{ours}_json").symlink_to(data_dir / TAKE / "openpose-body25b" / f"{theirs}_json")
    args = ("--cams", str(data_dir / TAKE / "calib_pose2sim.toml"), "--prior", prior_file, "--samples", "4")
    common = (*args, "--fps", "60", "--image-size", "1920x1088", "--threads", "1", "--formats", "npz", "-q")
    code, out, err = run_cli("lift", "--keypoints", str(folder), "--out", str(tmp_path / "o"), *common)
    assert code == 0, err
    lines = [line for line in err.splitlines() if "median motion lies" in line]
    assert len(lines) == 1 and "cam_01, cam_02, cam_03, cam_04 (no view fits)" in lines[0], err
    assert "calibration does not fit" in lines[0], err
    code, out, err = run_cli(
        "lift", "--keypoints", str(data_dir / TAKE / "openpose-body25b"), "--out", str(tmp_path / "right"), *common
    )
    assert code == 0 and "no view fits" not in err, err  # the rig as it is: not every view is off


def test_calibration_names_matching_no_video_are_one_error(run_cli, data_dir, tmp_path, prior_file, batch_folder):
    folder = tmp_path / "in"
    folder.mkdir()
    for name in ("front.mp4", "side.mp4", "back.mp4", "top.mp4"):
        (folder / name).symlink_to(batch_folder / "good.mp4")
    code, out, err = run_cli(
        "lift", str(folder), "--cams", str(data_dir / TAKE / "calib_pose2sim.toml"), "--prior", prior_file,
        "--out", str(tmp_path / "out"), "--quiet",
    )  # fmt: skip
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "no camera matches a view by name" in err and "name each video" in err and "cam_01.mp4" in err
    assert not (tmp_path / "out").exists()
