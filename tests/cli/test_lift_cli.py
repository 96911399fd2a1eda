"""``platypose lift`` end to end on the real Pose2Sim take: 4 views and 1 view of OpenPose keypoints, a given root
path, keypoint folder matching errors, and a batch folder with a good, a corrupt and an empty video."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np
import pytest

TAKE = "video/pose2sim-balancing"


@pytest.fixture(scope="module")
def triangulated(data_dir):
    """Plain DLT triangulation (T, 17, 3) of the athlete from the 4 views' OpenPose keypoints, and the cameras."""
    from platypose.detectors.persons.multiview import match_across_views
    from platypose.detectors.sources.keypoint_source import read_keypoints
    from platypose.detectors.tracking.tracker import persons_to_keep
    from platypose.lifting.calibration import load_calibration
    from platypose.lifting.triangulation import triangulate

    cameras = list(load_calibration(data_dir / TAKE / "calib_pose2sim.toml").cameras)
    views = [read_keypoints(data_dir / TAKE / f"openpose-body25b/cam0{i}_json") for i in range(1, 5)]
    views = match_across_views(views, cameras)
    athlete = int(persons_to_keep(views, "largest")[0])
    keypoints = np.stack([v.keypoints[:, athlete] for v in views])
    return triangulate(keypoints[..., :2], keypoints[..., 2], cameras)


def lift_args(data_dir, prior_file, out, *extra: str) -> tuple[str, ...]:
    calib = str(data_dir / TAKE / "calib_pose2sim.toml")
    common = ("--prior", prior_file, "--out", str(out), "--samples", "6", "--threads", "1", "--quiet")
    return ("lift", "--cams", calib, *common, *extra)


def test_four_views_match_triangulation_and_one_view_spreads(
    run_cli, data_dir, tmp_path, prior_file, triangulated
) -> None:
    from platypose.exporters.npz import read_npz

    keypoints = data_dir / TAKE / "openpose-body25b"
    code, out, err = run_cli(
        *lift_args(
            data_dir,
            prior_file,
            tmp_path,
            "--keypoints",
            str(keypoints),
            "--persons",
            "largest",
            "--formats",
            "npz,csv",
        )
    )
    assert code == 0, err
    assert "1 ok, 0 failed" in out
    folder = tmp_path / "openpose-body25b"
    result = read_npz(folder / "openpose-body25b.npz")
    assert result.hypotheses.shape == (1, 6, 100, 17, 3)
    assert [c.name for c in result.cameras] == ["cam_01", "cam_02", "cam_03", "cam_04"]
    assert result.meta["root"] == ["triangulated"]
    seen = np.isfinite(triangulated).all(-1)
    error = np.linalg.norm(result.median[0] - triangulated, axis=-1)[seen]
    assert np.median(error) < 0.03, np.median(error)  # metres: 4 calibrated views pin every joint
    with open(folder / "openpose-body25b.csv", newline="") as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == 100 and len(rows[0]) == 4 + 17 * 4  # per frame: each joint's answer and its spread radius
    assert float(rows[50]["head_z_m"]) == round(float(result.median[0, 50, 10, 2]), 3)
    assert (folder / "openpose-body25b.csv").stat().st_size < 100 * 500  # under 500 bytes a frame: 1.8 MB/min at 60 fps
    log = (folder / "log.txt").read_text()
    assert "calibration says 1088x1920 px for camera cam_01" in log and "ok in" in log  # a note: the coded size
    assert "warning: calibration says" not in log and not [
        w for w in result.meta["warnings"] if "calibration says" in w
    ]
    reprojection = result.meta["reprojection_px"]  # OpenPose's views disagree by 9-21 px here, under 2 % of 1920
    assert list(reprojection) == ["cam_01", "cam_02", "cam_03", "cam_04"] and max(reprojection.values()) < 38.4
    assert "median motion against the keypoints" in log
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["inputs"][0]["status"] == "ok" and summary["inputs"][0]["error"] is None
    assert sorted(Path(p).name for p in summary["inputs"][0]["outputs"]) == [
        "openpose-body25b.csv",
        "openpose-body25b.npz",
        "openpose-body25b_gaps.json",
    ]

    one = tmp_path / "one"
    code, _, err = run_cli(
        *lift_args(
            data_dir,
            prior_file,
            one,
            "--keypoints",
            str(keypoints / "cam01_json"),
            "--persons",
            "largest",
            "--formats",
            "npz",
        )
    )
    assert code == 0, err
    single = read_npz(one / "cam01" / "cam01.npz")
    assert [c.name for c in single.cameras] == ["cam_01"] and single.meta["root"] == ["solved"]
    hyp = single.hypotheses[0]
    spread = np.linalg.norm(hyp - single.median[0], axis=-1).mean()
    assert spread > 0.01  # one view leaves depth open: the hypotheses differ
    from platypose.lifting.camera import project

    # every hypothesis reprojects onto cam01's keypoints (image plane pinned, depth free)
    pixels = project(single.median[0], single.cameras[0])
    observed = single.keypoints2d[0, 0]
    close = np.linalg.norm(pixels - observed[..., :2], axis=-1)[observed[..., 2] > 0.3]
    assert np.median(close) < 40, np.median(close)


def test_given_root_trajectory_npz_and_csv(run_cli, data_dir, tmp_path, prior_file, triangulated) -> None:
    from platypose.exporters.npz import read_npz

    times = np.arange(100) / 60.0
    root = triangulated[:, 0]
    keep = np.isfinite(root).all(-1)
    np.savez(tmp_path / "root.npz", frame_times=times[keep], root=root[keep])
    with open(tmp_path / "root.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["time", "x", "y", "z"])
        writer.writerows([[t, *p] for t, p in zip(times[keep], root[keep])])
    keypoints = str(data_dir / TAKE / "openpose-body25b" / "cam01_json")
    for name in ("root.npz", "root.csv"):
        out = tmp_path / name.replace(".", "_")
        args = lift_args(
            data_dir,
            prior_file,
            out,
            "--keypoints",
            keypoints,
            "--persons",
            "largest",
            "--formats",
            "npz",
            "--root-trajectory",
            str(tmp_path / name),
        )
        code, _, err = run_cli(*args)
        assert code == 0, err
        result = read_npz(out / "cam01" / "cam01.npz")
        assert result.meta["root"] == ["given"]
        pelvis = result.hypotheses[0, :, keep, 0]  # (frames, N, 3)
        # the path goes through the prior's 30 fps clock and back: odd frames are interpolated (< 2 cm here)
        np.testing.assert_allclose(pelvis, np.broadcast_to(root[keep][:, None], pelvis.shape), atol=0.02)
        assert np.median(np.abs(pelvis - root[keep][:, None])) < 0.002


def test_one_view_depth_smoothness_calms_depth_and_is_checked(run_cli, data_dir, tmp_path, prior_file) -> None:
    """``--depth-smoothness``: with one view the hypotheses' depth paths accelerate less with it than without
    (0); a negative value is a one-line error. Without the floor: grounding holds stance ankles where they stand,
    unsmoothed (tests/lifting/sampling/test_grounding.py). One view's limbs are rebuilt at adult lengths after
    smoothing (lifting/anatomy/lengths.py), which scales the tiny test prior's short limbs, and their joints'
    accelerations with them, smoothed or not: the smoothed paths keep at most 80 % of the unsmoothed ones'
    (about 75 %; under 70 % without the rebuild)."""
    from platypose.exporters.npz import read_npz

    keypoints = str(data_dir / TAKE / "openpose-body25b" / "cam01_json")
    acceleration = {}
    for value in ("0", "10"):
        out = tmp_path / value
        code, _, err = run_cli(
            *lift_args(
                data_dir,
                prior_file,
                out,
                "--keypoints",
                keypoints,
                "--persons",
                "largest",
                "--formats",
                "npz",
                "--depth-smoothness",
                value,
                "--floor",
                "none",
            )
        )
        assert code == 0, err
        result = read_npz(out / "cam01" / "cam01.npz")
        cam = result.cameras[0]
        depth = (result.hypotheses[0] @ cam.R.T + cam.t)[..., 2]  # (N, T, 17)
        acceleration[value] = np.nanpercentile(np.abs(np.diff(depth, 2, axis=1)), 99)
    assert acceleration["10"] < 0.8 * acceleration["0"], acceleration
    code, _, err = run_cli(
        *lift_args(data_dir, prior_file, tmp_path / "bad", "--keypoints", keypoints, "--depth-smoothness", "-1")
    )
    assert code == 2 and "--depth-smoothness must be >= 0" in err and len(err.strip().splitlines()) == 1, err


def test_keypoint_views_must_match_cameras(run_cli, data_dir, tmp_path, prior_file) -> None:
    source = data_dir / TAKE / "openpose-body25b"
    views = tmp_path / "views"
    views.mkdir()
    (views / "cam01_json").symlink_to(source / "cam01_json")
    (views / "left_json").symlink_to(source / "cam02_json")
    code, _, err = run_cli(*lift_args(data_dir, prior_file, tmp_path / "o", "--keypoints", str(views)))
    assert code == 2
    assert "left" in err and "match no camera" in err and str(views) in err
    args = ("lift", "--keypoints", str(views), "--prior", prior_file, "--out", str(tmp_path / "o"))
    code, _, err = run_cli(*args)
    assert code == 2 and "need --cams" in err


def test_batch_records_failures_and_resume_skips_finished(run_cli, tmp_path, prior_file, batch_folder) -> None:
    from platypose.exporters.npz import read_npz

    args = (
        "lift",
        str(batch_folder),
        "--prior",
        prior_file,
        "--out",
        str(tmp_path),
        "--samples",
        "4",
        "--formats",
        "npz,bvh",
        "--persons",
        "largest",
        "--quiet",
        "--jobs",
        "2",
    )
    code, out, err = run_cli(*args)
    assert code == 2  # both failures are bad inputs (the README's exit code)
    assert "3 input(s): 1 ok, 2 failed, 0 skipped" in out
    assert "warning: good:" not in err  # no --cams is what one phone gives: said in the log and meta, not warned
    summary = json.loads((tmp_path / "summary.json").read_text())
    by_name = {Path(e["input"]).name: e for e in summary["inputs"]}
    assert [Path(e["input"]).name for e in summary["inputs"]] == ["corrupt.mp4", "empty.mp4", "good.mp4"]
    assert summary["counts"] == {"ok": 1, "failed": 2, "skipped": 0}
    assert by_name["good.mp4"]["status"] == "ok" and by_name["good.mp4"]["seconds"] > 0
    assert by_name["corrupt.mp4"]["status"] == "failed" and "corrupt.mp4" in by_name["corrupt.mp4"]["error"]
    assert by_name["empty.mp4"]["error"].endswith("no person found")
    assert "\n" not in by_name["corrupt.mp4"]["error"] + by_name["empty.mp4"]["error"]
    npz = tmp_path / "good" / "good.npz"
    result = read_npz(npz)
    assert result.hypotheses.shape[:3] == (1, 4, 12) and result.cameras[0].size == (960, 540)
    assert "no --cams" in " ".join(result.meta["notes"]) and result.meta["warnings"] == []
    assert by_name["good.mp4"]["warnings"] == result.meta["warnings"]  # and summary.json
    assert (tmp_path / "good" / "good_p0.bvh").read_text().startswith("HIERARCHY")
    assert "no person found" in (tmp_path / "empty" / "log.txt").read_text()
    assert not list(tmp_path.glob(".*partial")) and not list(tmp_path.rglob(".*.tmp"))

    watched = (npz, tmp_path / "empty" / "log.txt", tmp_path / "corrupt" / "log.txt")
    stamps = [p.stat().st_mtime_ns for p in watched]
    code, out, _ = run_cli(*args[:-2], "--resume")
    assert code == 2 and "0 ok, 2 failed, 1 skipped" in out  # nothing is run again
    assert [p.stat().st_mtime_ns for p in watched] == stamps
    entries = json.loads((tmp_path / "summary.json").read_text())["inputs"]
    assert [e["status"] for e in entries] == ["failed", "failed", "skipped"]
    assert entries[1]["error"] == "earlier run: " + by_name["empty.mp4"]["error"]
    assert entries[2]["outputs"] == by_name["good.mp4"]["outputs"]
    code, out, _ = run_cli(*args[:-2], "--resume", "--retry-failed")
    assert code == 2 and "0 ok, 2 failed, 1 skipped" in out
    assert (tmp_path / "empty" / "log.txt").stat().st_mtime_ns > stamps[1]  # tried again


def test_interrupted_export_leaves_earlier_outputs(monkeypatch, tmp_path) -> None:
    import platypose.exporters as exporters
    from platypose.cli.runs.outputs import export_atomically, staging_folder
    from platypose.lifting.job_log import JobLog

    folder = tmp_path / "take"
    folder.mkdir()
    (folder / "take.npz").write_bytes(b"earlier result")

    def interrupted(result, out_dir, name, *args, **kwargs):
        (Path(out_dir) / f"{name}.npz").write_bytes(b"half")
        raise KeyboardInterrupt

    monkeypatch.setattr(exporters, "export", interrupted)
    with pytest.raises(KeyboardInterrupt), staging_folder(folder, "take") as staging:
        export_atomically(None, {}, staging, folder, "take", ("npz",), JobLog())
    assert (folder / "take.npz").read_bytes() == b"earlier result"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["take"]


def test_a_lifts_opensim_ik_warnings_are_its_warnings(data_dir, tmp_path) -> None:
    """OpenSim's IK warnings of a lift go into its log's warnings (summary.json, the console, the npz's meta), not
    only into log.txt as progress lines."""
    pytest.importorskip("opensim")
    from export_helpers import two_person_result

    from platypose.cli.runs.outputs import export_atomically, staging_folder
    from platypose.exporters.npz import read_npz
    from platypose.lifting.job_log import JobLog

    result = two_person_result(data_dir)
    log = JobLog()
    result = result.with_meta(warnings=log.warnings)  # as the pipeline's result holds its log's warnings
    folder = tmp_path / "clip"
    folder.mkdir()
    with staging_folder(folder, "clip") as staging:
        export_atomically(result, {}, staging, folder, "clip", ("npz", "mot"), log)
    assert [w.split(":")[0] for w in log.warnings] == ["person 0 OpenSim IK", "person 7 OpenSim IK"]
    assert all("marker RMS" in w and "(over 3)" in w for w in log.warnings)
    assert read_npz(folder / "clip.npz").meta["warnings"] == log.warnings


def test_demo_lifts_the_bundled_take(run_cli, tmp_path, prior_file) -> None:
    from platypose.exporters.npz import read_npz

    args = (
        "demo",
        "--out",
        str(tmp_path),
        "--source",
        "keypoints",
        "--prior",
        prior_file,
        "--samples",
        "4",
        "--threads",
        "1",
        "--quiet",
    )
    code, out, err = run_cli(*args)
    assert code == 0, err
    folder = tmp_path / "openpose-body25b"
    assert f"in {folder}/" in out and "1 person(s) x 4 hypotheses x 100 frames" in out
    assert f"look at it: {sys.executable} -m rerun {folder / 'openpose-body25b.rrd'}" in out
    result = read_npz(folder / "openpose-body25b.npz")
    assert len(result.cameras) == 4 and result.num_persons == 1
    pelvis = np.median(result.median[0, :, 0, 2])
    assert 0.8 < pelvis < 1.1 and f"pelvis {pelvis:.2f} m" in out  # a standing adult, floor at z = 0
    assert {p.suffix for p in folder.iterdir()} >= {".npz", ".csv", ".bvh", ".rrd"}


def test_calibration_mismatches_fail_their_input(run_cli, data_dir, tmp_path, prior_file, batch_folder) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "cam01.mp4").symlink_to(batch_folder / "good.mp4")  # cam01 at half the calibrated size
    (folder / "side.mp4").symlink_to(batch_folder / "good.mp4")  # no camera of that name
    code, out, _ = run_cli(*lift_args(data_dir, prior_file, tmp_path / "out", str(folder)))
    assert code == 2 and "0 ok, 2 failed" in out  # bad inputs only: exit 2
    errors = {e["name"]: e["error"] for e in json.loads((tmp_path / "out" / "summary.json").read_text())["inputs"]}
    assert "calibration mismatch: calibration says 1088x1920 px for camera cam_01" in errors["cam01"]
    assert "is 540x960" in errors["cam01"]
    assert "calibration mismatch" in errors["side"] and "side match no camera" in errors["side"]
    assert not (tmp_path / "out" / "side" / "side.detections.npz").exists()  # refused before detecting


def test_a_short_track_at_a_low_rate_lifts(run_cli, data_dir, tmp_path, prior_file) -> None:
    """A truncated real video lifted every 10th frame (7 frames at 6 fps, 16-frame windows of the prior at 30 fps):
    the input frames lie five prior frames apart, and stitching the windows once broadcast 2 frames against 16. The
    recording, which rerun cannot embed the truncated MP4 in (it failed the input), holds its decoded frames as JPEG."""
    from export_helpers import read_entities
    from media_helpers import truncated_copy

    from platypose.exporters.npz import read_npz

    video = truncated_copy(data_dir / TAKE / "cam01.mp4", tmp_path / "cam01.mp4", 0.6)
    code, _, err = run_cli(
        *lift_args(data_dir, prior_file, tmp_path / "out", str(video), "--stride", "10", "--formats", "npz,rrd")
    )
    assert code == 0, err
    result = read_npz(tmp_path / "out" / "cam01" / "cam01.npz")
    assert 5 <= result.num_frames <= 9 and result.hypotheses.shape[1] == 6
    assert np.isfinite(result.hypotheses).all()
    video = read_entities(tmp_path / "out" / "cam01" / "cam01.rrd")["/world/cameras/cam_01/video"]
    assert len(video["EncodedImage:blob"]) >= 60  # the frames that decode (61 of 100; rows per timeline)
    assert all(m == ["image/jpeg"] for m in video["EncodedImage:media_type"])
    assert all(blob[:3] == b"\xff\xd8\xff" for blob in video["EncodedImage:blob"])
