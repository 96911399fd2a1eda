"""Time offsets of unsynchronised views from 2D keypoints: the bundled 4-view take with known shifts added."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.lifting.calibration import load_calibration
from platypose.lifting.sync.offsets import estimate_offsets, lag_correlation, main_person, sample_at, with_offsets

TAKE = "video/pose2sim-balancing"


@pytest.fixture(scope="module")
def take(data_dir: Path):
    """Cameras, one person's keypoints (T, 17, 3) per view and frame times of the bundled take (60 fps)."""
    cal = load_calibration(data_dir / TAKE / "calib_pose2sim.toml")
    folders = [data_dir / TAKE / "openpose-body25b" / f"cam0{i}_json" for i in range(1, 5)]
    tracks = [read_openpose_folder(f, fps=60, image_size=c.size) for f, c in zip(folders, cal.cameras)]
    return cal.cameras, [main_person(t.keypoints) for t in tracks], [t.frame_times for t in tracks]


def test_known_shifts_recovered(take):
    """Views 2 and 4 made to start 20 and 12 frames late: the offsets grow by those amounts (within half a frame)."""
    cameras, views, times = take
    base = estimate_offsets(views, times, cameras)
    shifted_views, shifted_times = list(views), list(times)
    for c, shift in ((1, 20), (3, 12)):
        shifted_views[c] = views[c][shift:]
        shifted_times[c] = times[c][: len(views[c]) - shift]  # the late camera's own clock starts at 0
    estimate = estimate_offsets(shifted_views, shifted_times, cameras)
    change = estimate.offsets_frames - base.offsets_frames
    assert abs(change[1] - 20) < 0.5 and abs(change[3] - 12) < 0.5, change
    assert abs(change[2]) < 1.5 and change[0] == 0
    assert np.all(estimate.confidence[1:] > 0.3) and np.all(estimate.correlation[1:] > 0.6)
    assert estimate.error_after_px < 13.0 < estimate.error_before_px  # unsynchronised views disagree


def test_offsets_put_views_on_one_clock(take):
    cameras, views, times = take
    moved = with_offsets(cameras, [0.0, 0.1, -0.2, 0.3])
    assert [c.time_offset_s for c in moved] == [0.0, 0.1, -0.2, 0.3] and moved[1].name == cameras[1].name


def test_lag_correlation_finds_a_shifted_signal():
    rng = np.random.default_rng(0)
    reference = np.convolve(rng.normal(size=400), np.ones(5) / 5, mode="same")
    lags, corr = lag_correlation(reference, reference[7:300], 30)
    assert lags[np.nanargmax(corr)] == 7 and np.nanmax(corr) == pytest.approx(1.0)


def test_sample_at_interpolates_and_marks_gaps():
    keypoints = np.zeros((3, 1, 3))
    keypoints[:, 0, 0] = [0.0, 10.0, 20.0]
    keypoints[:, 0, 2] = [1.0, 0.0, 1.0]  # the middle frame is unseen
    out = sample_at(keypoints, np.array([0.0, 1.0, 2.0]), np.array([0.25, 1.5, 2.0, 3.0]))
    assert out[0, 0, 0] == pytest.approx(2.5) and out[3, 0, 2] == 0.0
    assert out[0, 0, 2] == 0.0 and out[2, 0, 2] == 1.0  # across the unseen frame: no confidence


def _check(run_cli, data_dir: Path, sync: str):
    take = data_dir / TAKE
    args = ("calib", "check", str(take / "calib_pose2sim.toml"), "--keypoints", str(take / "openpose-body25b"))
    return run_cli(*args, "--fps", "60", "--sync", sync)


def test_calib_check_reports_offsets(run_cli, data_dir: Path, tmp_path: Path):
    code, stdout, _ = _check(run_cli, data_dir, "auto")
    assert code == 0 and stdout.count("confidence") == 3 and "sync cam_02:" in stdout
    assert "px with the calibration's offsets, " in stdout and "px with those used" in stdout
    offsets = tmp_path / "offsets.json"
    offsets.write_text('{"cam01": 0.0, "cam02": 0.0, "cam_03": -0.0833, "CAM-4": 0.0}')
    code, stdout, _ = _check(run_cli, data_dir, str(offsets))
    assert code == 0 and "cam_03: median reprojection error" in stdout and "time offset -0.083 s" not in stdout


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"cam01": 0.0, "cam02": 0.1, "cam03": 0.2}', "no view for camera.s. cam_04"),
        ('{"cam01": "late"}', "camera name -> offset in seconds"),
        ("[1, 2]", "camera name -> offset in seconds"),
        ("{oops", "not valid JSON"),
    ],
)
def test_bad_offsets_file(run_cli, data_dir: Path, tmp_path: Path, text: str, message: str):
    offsets = tmp_path / "offsets.json"
    offsets.write_text(text)
    code, _, stderr = _check(run_cli, data_dir, str(offsets))
    assert code == 2 and re.search(message, stderr) and f"error: {offsets}: " in stderr
    assert len(stderr.strip().splitlines()) == 1


def test_missing_offsets_file(run_cli, data_dir: Path, tmp_path: Path):
    code, _, stderr = _check(run_cli, data_dir, str(tmp_path / "nope.json"))
    assert code == 2 and "offsets file not found" in stderr


def _late_take(data_dir: Path, folder: Path, shifts: dict[str, int]) -> Path:
    """The bundled OpenPose take with the views in ``shifts`` started that many frames late (files renumbered)."""
    for view in sorted((data_dir / TAKE / "openpose-body25b").iterdir()):
        files = sorted(view.glob("*.json"))[shifts.get(view.name, 0) :]
        (folder / view.name).mkdir(parents=True)
        camera = view.name.removesuffix("_json")
        for i, path in enumerate(files):
            (folder / view.name / f"{camera}.{i:04d}.json").write_bytes(path.read_bytes())
    return folder


def test_lift_with_sync_auto_matches_the_synchronised_lift(run_cli, data_dir: Path, prior_file: str, tmp_path: Path):
    """cam02 and cam04 made 20 and 12 frames late: --sync auto finds it, writes it, and lifts like the original."""
    from platypose.exporters.npz import read_npz

    def lift(take: Path, out: Path, sync: str):
        args = ("lift", "--keypoints", str(take), "--cams", str(data_dir / TAKE / "calib_pose2sim.toml"))
        options = (
            "--fps",
            "60",
            "--image-size",
            "1920x1088",
            "--prior",
            prior_file,
            "--samples",
            "2",
            "--persons",
            "largest",
        )
        code, stdout, stderr = run_cli(*args, *options, "--sync", sync, "--out", str(out), "--formats", "npz", "-q")
        assert code == 0, stdout + stderr
        return read_npz(next(out.rglob("*.npz"))), out

    late = _late_take(data_dir, tmp_path / "late", {"cam02_json": 20, "cam04_json": 12})
    synced, out = lift(late, tmp_path / "auto", "auto")
    original, _ = lift(_late_take(data_dir, tmp_path / "original", {}), tmp_path / "none", "none")
    written = json.loads(next(out.rglob("sync_offsets.json")).read_text())
    offsets = written["offsets_s"]
    assert abs(offsets["cam_02"] * 60 - 20) < 0.5 and abs(offsets["cam_04"] * 60 - 12) < 0.5
    assert [c.time_offset_s for c in synced.cameras] == list(offsets.values())
    assert synced.meta["sync"] == written and written["mode"] == "auto"
    assert "sync cam_02: estimated +0.333 s" in next(out.rglob("log.txt")).read_text()
    gap = np.linalg.norm(synced.median[0] - original.median[0], axis=-1) * 1000
    print(f"median joint difference, --sync auto on the late take vs the original: {np.nanmedian(gap):.1f} mm")
    assert np.nanmedian(gap) < 15.0

    # the Python API on the same late take: the same offsets, whether estimated or read from the CLI's file
    import platypose

    said: list[str] = []
    views = sorted(late.iterdir())
    common = dict(fps=60, image_size=(1920, 1088), prior=prior_file, samples=2, persons="largest", say=said.append)
    calib = data_dir / TAKE / "calib_pose2sim.toml"
    estimated = platypose.lift(views, calib, sync="auto", **common)
    frames = {name: round(value * 60, 2) for name, value in estimated.meta["sync"]["offsets_s"].items()}
    print(
        f"offsets in frames, API sync='auto': {frames}; CLI --sync auto: {[round(v * 60, 2) for v in offsets.values()]}"
    )
    assert estimated.meta["sync"] == written and [c.time_offset_s for c in estimated.cameras] == list(offsets.values())
    assert any(line.startswith("sync cam_02: estimated +0.333 s") and line.endswith("+0.333 s used") for line in said)
    from_file = platypose.lift(views, calib, sync=next(out.rglob("sync_offsets.json")), **common)
    by_name = platypose.lift(
        views,
        calib,
        sync={"cam02": offsets["cam_02"], "cam_04": offsets["cam_04"], "cam01": 0.0, "cam03": offsets["cam_03"]},
        **common,
    )
    for result in (from_file, by_name):
        assert result.meta["sync"] == {"mode": "offsets", "offsets_s": offsets}
        assert np.array_equal(result.median, estimated.median)  # same offsets, same seed: the same lift


def test_api_sync_refuses_bad_choices(data_dir: Path, tmp_path: Path):
    import platypose
    from platypose.lifting.errors import InputError

    views = sorted((data_dir / TAKE / "openpose-body25b").iterdir())
    calib = data_dir / TAKE / "calib_pose2sim.toml"
    with pytest.raises(InputError, match="offsets file not found"):
        platypose.lift(views, calib, sync=tmp_path / "nope.json", fps=60)
    with pytest.raises(InputError, match="no view for camera.s. cam_04"):
        platypose.lift(views, calib, sync={"cam01": 0.0, "cam02": 0.1, "cam03": 0.2}, fps=60, image_size=(1920, 1088))
