"""--resume, staging folders, warnings, summary.json, stale outputs,
SIGTERM and Ctrl-C, on real OpenPose keypoints of the Pose2Sim take with the tiny prior."""

from __future__ import annotations

import errno
import json
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

TAKE = "video/pose2sim-balancing"


def keypoints(data_dir: Path, folder: Path, view: str = "cam01", frames: int = 12) -> Path:
    """The first ``frames`` real OpenPose files of ``view`` copied to ``folder/<view>_json``."""
    target = folder / f"{view}_json"
    target.mkdir(parents=True)
    for path in sorted((data_dir / TAKE / f"openpose-body25b/{view}_json").glob("*.json"))[:frames]:
        shutil.copy(path, target / path.name)
    return target


def lift(data_dir, prior_file, source: Path, out: Path, *extra) -> list[str]:
    calib = data_dir / TAKE / "calib_pose2sim.toml"
    timing = ("--fps", "60", "--image-size", "1920x1088")
    fast = ("--samples", "2", "--steps", "3", "--skip", "1", "--guidance-iters", "1", "--threads", "1", "-q")
    return ["lift", "--keypoints", str(source), "--cams", str(calib), "--prior", prior_file, *timing, *fast] + [
        "--out",
        str(out),
        *map(str, extra),
    ]


def summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def hypotheses(npz: Path) -> int:
    with np.load(npz) as data:
        return data["hypotheses"].shape[1]


def test_resume_reruns_when_settings_change_and_says_why(run_cli, data_dir, prior_file, tmp_path):
    source, out = keypoints(data_dir, tmp_path), tmp_path / "out"
    assert run_cli(*lift(data_dir, prior_file, source, out, "--formats", "npz"))[0] == 0
    code, _, err = run_cli(*lift(data_dir, prior_file, source, out, "--formats", "npz", "--resume"))
    assert code == 0
    entry = summary(out)["inputs"][0]
    assert entry["status"] == "skipped" and entry["reason"] == "finished earlier with the same inputs and settings"
    argv = lift(data_dir, prior_file, source, out, "--formats", "npz", "--resume")
    argv[argv.index("--samples") + 1] = "4"
    code, _, _ = run_cli(*argv)
    assert code == 0 and summary(out)["inputs"][0]["status"] == "ok"
    assert hypotheses(out / "cam01/cam01.npz") == 4  # 2 were kept before the fix, with exit 0


def test_lift_json_is_output_relative_and_resume_works_from_elsewhere(
    run_cli, data_dir, prior_file, tmp_path, monkeypatch
):
    source = keypoints(data_dir, tmp_path).resolve()
    (tmp_path / "a").mkdir()
    monkeypatch.chdir(tmp_path / "a")
    assert run_cli(*lift(data_dir, prior_file, source, Path("out"), "--formats", "npz"))[0] == 0
    manifest = json.loads((tmp_path / "a/out/cam01/lift.json").read_text())
    assert manifest["outputs"] == ["cam01.npz"] and len(manifest["fingerprint"]) == 64
    monkeypatch.chdir(tmp_path)
    shutil.move(tmp_path / "a", tmp_path / "b")
    monkeypatch.chdir(tmp_path / "b")
    assert run_cli(*lift(data_dir, prior_file, source, Path("out"), "--formats", "npz", "--resume"))[0] == 0
    entry = summary(tmp_path / "b/out")["inputs"][0]
    assert entry["status"] == "skipped" and Path(entry["outputs"][0]).is_file()


def test_a_failed_rerun_keeps_the_good_run_and_its_log(run_cli, data_dir, prior_file, tmp_path):
    source, out = keypoints(data_dir, tmp_path), tmp_path / "out"
    assert run_cli(*lift(data_dir, prior_file, source, out, "--formats", "npz"))[0] == 0
    good_log, good_npz = (out / "cam01/log.txt").read_text(), (out / "cam01/cam01.npz").read_bytes()
    broken = sorted(source.glob("*.json"))[3]
    content = json.loads(broken.read_text())
    content["people"][0]["pose_keypoints_2d"][0] = 1e30
    broken.write_text(json.dumps(content))
    code, _, err = run_cli(*lift(data_dir, prior_file, source, out, "--formats", "npz", "--resume"))
    assert code == 2 and "far outside" in err  # the input changed: run again, and it fails
    assert (out / "cam01/log.txt").read_text() == good_log
    assert (out / "cam01/cam01.npz").read_bytes() == good_npz
    assert "far outside" in (out / "cam01/log-failed.txt").read_text()
    assert summary(out)["inputs"][0]["error_kind"] == "input"


def test_transient_failures_are_retried_by_resume(run_cli, data_dir, prior_file, tmp_path, monkeypatch):
    import platypose.exporters as exporters

    source, out = keypoints(data_dir, tmp_path), tmp_path / "out"
    real_export = exporters.export

    def full_disk(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(out / "cam01" / "cam01.npz"))

    monkeypatch.setattr(exporters, "export", full_disk)
    code, _, err = run_cli(*lift(data_dir, prior_file, source, out, "--formats", "npz"))
    assert code == 1 and "No space left on device" in err  # not bad input: exit 1
    failure = json.loads((out / "cam01/failed.json").read_text())
    assert failure["transient"] is True and summary(out)["inputs"][0]["error_kind"] == "system"
    monkeypatch.setattr(exporters, "export", real_export)
    code, _, err = run_cli(*lift(data_dir, prior_file, source, out, "--formats", "npz", "--resume"))
    assert code == 0 and summary(out)["inputs"][0]["status"] == "ok"


def test_stale_staging_and_stale_outputs_are_removed(run_cli, data_dir, prior_file, tmp_path):
    source, out = keypoints(data_dir, tmp_path), tmp_path / "out"
    (out / "cam01").mkdir(parents=True)
    dead = out / ".cam01.999999999.abc.partial"  # a killed run's staging folder (no such process)
    dead.mkdir()
    (dead / ".hypotheses.npy").write_bytes(b"\0" * 1000)
    alive = out / f".cam01.{os.getpid()}.xyz.partial"  # a running process's: left alone
    alive.mkdir()
    (out / "cam01/cam01_p7.bvh").write_text("HIERARCHY\n")  # a person of an earlier run
    (out / "cam01/notes.txt").write_text("mine")  # not a platypose output: kept
    assert run_cli(*lift(data_dir, prior_file, source, out, "--formats", "npz,bvh"))[0] == 0
    assert not dead.exists() and alive.exists()
    names = sorted(p.name for p in (out / "cam01").iterdir())
    assert "cam01_p7.bvh" not in names and "notes.txt" in names and "cam01.npz" in names
    assert "removed output(s) of an earlier run" in (out / "cam01/log.txt").read_text()


def _write_entries(out: str, name: str, count: int) -> None:
    from platypose.cli.runs.batch import write_summary

    for i in range(count):
        entry = {"input": name, "name": name, "status": "ok", "outputs": [], "seconds": float(i), "error": None}
        write_summary(Path(out), [entry], "now", {})


def test_concurrent_runs_into_one_out_keep_every_entry(tmp_path):
    context = multiprocessing.get_context("spawn")
    processes = [context.Process(target=_write_entries, args=(str(tmp_path), f"take{i}", 15)) for i in range(3)]
    for process in processes:
        process.start()
    for process in processes:
        process.join(60)
    content = summary(tmp_path)
    assert sorted(e["name"] for e in content["inputs"]) == ["take0", "take1", "take2"]
    assert content["counts"]["ok"] == 3


def test_swapped_calibration_is_named_in_the_console_and_summary(run_cli, data_dir, prior_file, tmp_path):
    full = tmp_path / "full.json"
    assert run_cli("calib", "convert", data_dir / TAKE / "calib_pose2sim.toml", "--out", full)[0] == 0
    content = json.loads(full.read_text())
    cams = {c["name"]: c for c in content["cameras"]}
    for key in set(cams["cam_01"]) - {"name", "size", "K", "dist"}:
        cams["cam_01"][key], cams["cam_02"][key] = cams["cam_02"][key], cams["cam_01"][key]
    swapped = tmp_path / "swapped.json"
    swapped.write_text(json.dumps(content))
    views = tmp_path / "views"
    for view in ("cam01", "cam02", "cam03"):
        keypoints(data_dir, views, view, frames=20)
    argv = lift(data_dir, prior_file, views, tmp_path / "out", "--formats", "npz", "--persons", "largest")
    argv[argv.index("--cams") + 1] = str(swapped)
    code, _, err = run_cli(*argv)
    assert code == 0
    warnings = " ".join(summary(tmp_path / "out")["inputs"][0]["warnings"])
    assert "cam_01" in warnings and "cam_02" in warnings and "calibration" in warnings
    assert "warning: " in err and "calibration" in err


def _lift_process(argv: list[str]) -> subprocess.Popen:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.Popen(
        [sys.executable, "-m", "platypose", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        preexec_fn=_default_signals,
    )


def _default_signals() -> None:
    """A background shell starts its jobs with Ctrl-C ignored, which children inherit: give the lift Python's own."""
    signal.signal(signal.SIGINT, signal.default_int_handler)


def test_sigterm_removes_the_staging_folder(data_dir, prior_file, tmp_path):
    source, out = keypoints(data_dir, tmp_path, frames=100), tmp_path / "out"
    argv = lift(data_dir, prior_file, source, out, "--formats", "npz")
    argv[argv.index("--samples") + 1] = "64"
    process = _lift_process(argv)
    deadline = time.monotonic() + 120
    while not list(out.glob(".*.partial")) and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert process.poll() is None, process.communicate()[1]
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode != 0 and "Traceback" not in err
    assert list(out.glob(".*.partial")) == [] and not (out / "cam01/lift.json").exists()


def test_ctrl_c_with_two_jobs_keeps_finished_inputs(data_dir, prior_file, tmp_path):
    out = tmp_path / "out"
    videos = [data_dir / TAKE / f"cam0{i}.mp4" for i in (1, 2, 3, 4)]
    argv = ["lift", *map(str, videos), "--prior", prior_file, "--samples", "2", "--steps", "3", "--skip", "1"]
    argv += ["--stride", "3", "--jobs", "2", "--threads", "1", "--formats", "npz", "-q", "--out", str(out)]
    process = _lift_process(argv)
    deadline = time.monotonic() + 300
    while not list(out.glob("*/lift.json")) and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    if process.poll() is not None:
        pytest.skip("the batch finished before it could be interrupted")
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130 and "Traceback" not in err, err
    finished = sorted(p.parent.name for p in out.glob("*/lift.json"))
    listed = sorted(e["name"] for e in summary(out)["inputs"] if e["status"] == "ok")
    assert finished and finished == listed
    assert list(out.glob(".*.partial")) == []


def test_staging_folder_of_a_long_job_name(tmp_path):
    """File names over ~225 characters; the staging folder name stays short enough."""
    from platypose.cli.runs.outputs import remove_stale_staging, staging_folder

    name = "x" * 240
    with staging_folder(tmp_path / name, name) as staging:
        assert staging.is_dir() and len(staging.name) < 100
        (staging / f"{name}_hypotheses.csv").write_text("ok")  # the longest output name fits beside it
    stale = tmp_path / f".{name[:64]}.999999999.abc.partial"
    stale.mkdir()
    assert remove_stale_staging(tmp_path, name) == [stale.name]
