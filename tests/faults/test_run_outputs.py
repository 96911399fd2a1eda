"""What runs leave behind in --out and what they say: full disks, --out where it cannot be, resume (settings
changed, another working directory, a failed rerun keeping the good run, transient failures retried, the flags found
said again), staging folders and stale outputs, SIGTERM and Ctrl-C, concurrent runs (summary.json keeps every entry;
two lifts of one input at once: the second writer of a folder refuses, and the folder holds one run's files, as its
lift.json says, never a mix), warnings in summary.json and on the console, the npz written whatever the formats, exit
codes and quiet output. The cases without a marker lift the first frames of the Pose2Sim take's real OpenPose
keypoints with the tiny prior; the audit cases (marker ``audit``, run with ``pytest -m audit``) run the real CLI with
the shipped prior, each ending in a clean error or handled well (:mod:`audit_support`)."""

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
from audit_support import (
    CALIB,
    FAST,
    KEYPOINT_TIMING,
    TAKE,
    WALK,
    Case,
    Run,
    check_case,
    classify,
    default_signals,
    edit_json,
    fill,
    lift_args,
    openpose_copy,
    platypose,
    registry,
    result_npz,
    summary,
    tiny_lift_args,
    tmpfs,
    truncated_video,
)

from platypose.cli.runs.outputs import finished_outputs

CASES: list[Case] = []
case = registry(CASES)


@case("rrd-disk-full-x3")
def _(w: Path) -> Run:
    mount = tmpfs(w, "1m")
    if mount is None:
        return Run(skip="cannot mount a tmpfs")
    npz = result_npz(w)

    def action() -> tuple[str, str]:
        notes = []
        for _ in range(3):
            proc = platypose(
                ["export", npz, "--formats", "rrd", "--out", mount, "--video", f"cam_01={TAKE / 'cam04.mp4'}"], 120
            )
            outcome, note = classify(Run(timeout=120, says=("cam01.rrd: no space left on device while writing",)), proc)
            if outcome != "clean error":
                return outcome, note
            notes.append(note)
            if any(p.name.endswith(".tmp") or p.suffix == ".rrd" for p in mount.iterdir()):
                return "silent wrong", "a partial recording was left"
        return "clean error", notes[0]

    return Run(action=action)


def _resume_setup(w: Path, samples: str) -> tuple[Path, Path]:
    keypoints = openpose_copy(w / "kp")
    out = w / "out"
    done = platypose([*lift_args(keypoints, out), "--samples", samples, "--formats", "npz"], 240)
    assert done is not None and done.returncode == 0, done and done.stderr
    return keypoints, out


@case("resume-after-settings-changed")
def _(w: Path) -> Run:
    keypoints, out = _resume_setup(w, "2")

    def check(proc) -> str | None:
        with np.load(out / "cam01/cam01.npz", allow_pickle=False) as data:
            count = data["hypotheses"].shape[1]
        return None if count == 4 else f"stale: {count} hypotheses kept, 4 asked"

    return Run([*lift_args(keypoints, out), "--samples", "4", "--formats", "npz", "--resume"], "ok", check)


@case("resume-from-another-working-directory")
def _(w: Path) -> Run:
    keypoints = openpose_copy(w / "kp")
    (w / "a").mkdir()
    done = platypose([*lift_args(keypoints.resolve(), Path("out")), "--formats", "npz"], 240, cwd=w / "a")
    assert done is not None and done.returncode == 0, done and done.stderr
    shutil.move(str(w / "a"), str(w / "b"))

    def check(proc) -> str | None:
        entry = summary(w / "b/out")["inputs"][0]
        return None if entry["status"] == "skipped" else f"stale: not recognised as finished ({entry['status']})"

    return Run([*lift_args(keypoints.resolve(), Path("out")), "--formats", "npz", "--resume"], "ok", check, cwd=w / "b")


@case("failed-rerun-keeps-the-good-log")
def _(w: Path) -> Run:
    keypoints, out = _resume_setup(w, "4")
    good = (out / "cam01/log.txt").read_text()
    edit_json(sorted(keypoints.glob("*.json"))[2], lambda c: c["people"][0]["pose_keypoints_2d"].__setitem__(0, 1e30))

    def check(proc) -> str | None:
        if (out / "cam01/log.txt").read_text() != good:
            return "stale: the good run's log.txt was overwritten by the failed run"
        return None

    says = ("cam01_json", "frame 2: keypoint (0, 0) at (1e+30,", "lies far outside")
    return Run([*lift_args(keypoints, out), "--formats", "npz"], "error", check, says=says)


def _out_cases() -> None:
    says = {  # what the error says of OUT (the file written under it, for a full disk), by kind of OUT
        "is-a-file": ("afile", "is a file, an output folder was expected"),
        "is-a-folder": (": is a folder, an output file name was expected",),
        "under-a-file": ("afile/sub", "cannot write there (", "afile is a file, not a folder)"),
        "read-only": ("/fs-", "cannot write there (Read-only file system)"),
        "full-disk": ("/fs-", "No space left on device"),
        ("is-a-file", "detect"): ("afile/cam01: cannot write there (", "afile is a file, not a folder)"),
    }
    kinds = {
        "is-a-file": lambda w: _file(w),
        "is-a-folder": lambda w: w,
        "under-a-file": lambda w: _file(w) / "sub",
        "read-only": lambda w: tmpfs(w, "64k", read_only=True),
        "full-disk": lambda w: _full(w),
    }
    commands = {
        "detect": lambda w, out: ["detect", openpose_copy(w / "kp", frames=4), "--out", out, *KEYPOINT_TIMING, "-q"],
        "calib-convert": lambda w, out: ["calib", "convert", CALIB, "--out", out if out == w else out / "c.json"],
        "train": lambda w, out: ["train", WALK, "--out", out if out == w else out / "p.pt", "--iterations", "1"],
        "lift": lambda w, out: lift_args(openpose_copy(w / "kp", frames=4), out),
        "export": lambda w, out: ["export", result_npz(w), "--formats", "csv,bvh", "--out", out],
    }
    for command, make in commands.items():
        for kind, where in kinds.items():
            file_output = command in ("calib-convert", "train")
            if kind == ("is-a-file" if file_output else "is-a-folder"):
                continue  # a file output may replace a file; a folder output may be an existing folder

            def build(w: Path, make=make, where=where, words=says.get((kind, command), says[kind])) -> Run:
                out = where(w)
                if out is None:
                    return Run(skip="cannot mount a tmpfs")
                return Run(make(w, out), says=words)

            CASES.append(Case(f"out-{kind}-{command}", build))


def _file(w: Path) -> Path:
    (w / "afile").write_text("x")
    return w / "afile"


def _full(w: Path) -> Path | None:
    mount = tmpfs(w, "512k")
    if mount is not None:
        fill(mount)
    return mount


_out_cases()


@case("sigterm-leaves-no-staging")
def _(w: Path) -> Run:
    keypoints = openpose_copy(w / "kp", frames=60)
    out = w / "out"

    def action() -> tuple[str, str]:
        command = [sys.executable, "-m", "platypose", *map(str, lift_args(keypoints, out, "--samples", "16"))]
        env = {**os.environ, "OMP_NUM_THREADS": "1"}
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not any(out.glob(".*.partial")) and process.poll() is None:
            time.sleep(0.2)
        time.sleep(1.0)
        process.send_signal(signal.SIGTERM)
        try:
            _, err = process.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            process.kill()
            return "hang", "SIGTERM not obeyed in 60 s"
        left = [p.name for p in out.glob(".*.partial")]
        if left:
            return "stale data", f"stale: hidden staging left: {left}"
        if "Traceback" in err:
            return "traceback", err.strip().splitlines()[-1]
        again = platypose([*lift_args(keypoints, out), "--resume"], 240)
        if again is None:
            return "hang", "resume after SIGTERM"
        left = [p.name for p in out.glob(".*.partial")]
        return ("handled well", "no staging folder left") if not left else ("stale data", f"stale: {left}")

    return Run(action=action)


@case("concurrent-lifts-one-out")
def _(w: Path) -> Run:
    out = w / "out"
    sources = [openpose_copy(w / f"kp{i}", view) for i, view in enumerate(("cam01", "cam02", "cam03"))]

    def action() -> tuple[str, str]:
        env = {**os.environ, "OMP_NUM_THREADS": "1"}
        processes = [
            subprocess.Popen(
                [sys.executable, "-m", "platypose", *map(str, lift_args(s, out, "--formats", "npz"))],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                env=env,
            )
            for s in sources
        ]
        for process in processes:
            process.communicate(timeout=600)
        names = sorted(e["name"] for e in summary(out)["inputs"])
        if names != ["cam01", "cam02", "cam03"]:
            return "stale data", f"stale: summary.json lists {names}"
        return "handled well", "all three entries kept"

    return Run(action=action)


@case("stale-person-bvh-from-an-earlier-run")
def _(w: Path) -> Run:
    keypoints = openpose_copy(w / "kp")
    out = w / "out"
    (out / "cam01").mkdir(parents=True)
    (out / "cam01/cam01_p7.bvh").write_text("HIERARCHY\n")

    def check(proc) -> str | None:
        return (
            "stale: cam01_p7.bvh of an earlier run left beside the new results"
            if (out / "cam01/cam01_p7.bvh").exists()
            else None
        )

    return Run(lift_args(keypoints, out, "--formats", "npz,bvh"), "ok", check)


@case("jobs-2-ctrl-c")
def _(w: Path) -> Run:
    out = w / "out"
    inputs = [TAKE / f"cam0{i}.mp4" for i in (1, 2, 3, 4)]  # four one-view inputs, detected every 20th frame

    def action() -> tuple[str, str]:
        env = {**os.environ, "OMP_NUM_THREADS": "1"}
        command = [sys.executable, "-m", "platypose", "lift", *map(str, inputs), *FAST, "--stride", "20", "--jobs", "2"]
        command += ["--formats", "npz", "--out", str(out)]
        process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, preexec_fn=default_signals
        )
        deadline = time.monotonic() + 400
        while time.monotonic() < deadline and process.poll() is None and not list(out.glob("*/lift.json")):
            time.sleep(0.2)
        process.send_signal(signal.SIGINT)
        try:
            _, err = process.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            process.kill()
            return "hang", "Ctrl-C not obeyed"
        if "Traceback" in err:
            return "traceback", err.strip().splitlines()[-1][:160]
        finished = sorted(p.parent.name for p in out.glob("*/lift.json"))
        listed = sorted(e["name"] for e in summary(out)["inputs"] if e["status"] == "ok")
        if finished != listed:
            return "stale data", f"stale: finished {finished}, summary lists {listed}"
        return "handled well", f"{len(listed)} finished and listed, exit {process.returncode}"

    return Run(action=action, timeout=600)


@case("lift-exit-code-for-bad-per-input-value")
def _(w: Path) -> Run:
    folder = openpose_copy(w)
    edit_json(folder / "cam01.0002.json", lambda c: c["people"][0]["pose_keypoints_2d"].__setitem__(0, 1e30))
    return Run(
        lift_args(folder, w / "out"),
        check=lambda proc: None if proc.returncode == 2 else f"exit {proc.returncode}, README promises 2",
        says=("cam01_json", "frame 2: keypoint (0, 0) at (1e+30,", "lies far outside"),
    )


@case("detect-takes-q")
def _(w: Path) -> Run:
    return Run(["detect", openpose_copy(w, frames=4), "--out", w / "out", *KEYPOINT_TIMING, "-q"], "ok")


@case("quiet-means-quiet")
def _(w: Path) -> Run:
    video = truncated_video(w)

    def check(proc) -> str | None:
        noise = [line for line in proc.stderr.splitlines() if line.strip() and not line.startswith("warning:")]
        return f"stderr with -q: {noise[:2]}" if noise else None

    return Run(["detect", video, "--out", w / "out", "--stride", "10", "-q", "--threads", "1"], "ok", check)


def _ik_warned(out: Path, name: str, stderr: str) -> str | None:
    """None when the lift's OpenSim IK warnings are in summary.json and on the console (input ``name``); else what is
    missing."""
    warnings = [w for entry in summary(out)["inputs"] for w in entry["warnings"] if "OpenSim IK" in w]
    if not warnings:
        return "summary.json lists no OpenSim IK warning"
    if f"warning: {name}: {warnings[0]}" not in stderr:
        return "the console does not say the OpenSim IK warning"
    return None


@case("lift-says-opensim-ik-warnings")
def _(w: Path) -> Run:
    """Four views of the balancing take's first second: cam01 sees a person at its left edge whom cam02 sees
    elsewhere, so the views put together a body no model can take (bones 0.18 and 0.31 m for the two upper arms,
    0.3 m under the floor): OpenSim's IK follows its markers 8-10 cm off (seeds 0-2), well over the 3 cm it warns at."""
    keypoints = w / "kp"
    keypoints.mkdir()
    for view in ("cam01", "cam02", "cam03", "cam04"):
        openpose_copy(keypoints, view, frames=60)
    out = w / "out"
    return Run(lift_args(keypoints, out, "--formats", "npz,mot"), "ok", lambda proc: _ik_warned(out, "kp", proc.stderr))


@case("lift-writes-the-npz-whatever-the-formats")
def _(w: Path) -> Run:
    out = w / "out"
    args = [*lift_args(openpose_copy(w / "kp"), out, "--formats", "trc,angles")]
    return Run(args, "ok", lambda proc: None if (out / "cam01/cam01.npz").is_file() else "no npz written")


def _flag_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("  ") and ": flagged: " in line]


@case("resume-repeats-the-flags-it-found")
def _(w: Path) -> Run:
    keypoints = w / "kp"
    keypoints.mkdir()
    for view, source in (("cam01", "cam02"), ("cam02", "cam01"), ("cam03", "cam03"), ("cam04", "cam04")):
        openpose_copy(w / view, source).rename(keypoints / f"{view}_json")
    args = [*lift_args(keypoints, w / "out", "--formats", "npz"), "--resume"]  # cam01 and cam02 swapped: flags

    def action() -> tuple[str, str]:
        first = platypose(args, 240)
        assert first is not None and first.returncode == 0 and _flag_lines(first.stderr), first and first.stderr
        again = platypose(args, 240)
        if again is None or again.returncode != 0 or "1 skipped" not in again.stdout:
            return "silent wrong", f"the resumed run did not skip the input: {again and again.stdout}"
        if _flag_lines(again.stderr) != _flag_lines(first.stderr):
            return "silent wrong", f"the resumed run says {_flag_lines(again.stderr)}, not {_flag_lines(first.stderr)}"
        return "handled well", "ok"

    return Run(action=action)


@pytest.mark.audit
@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)


@pytest.mark.audit
def test_two_lifts_of_one_input_at_once_do_not_mix_their_files(tmp_path) -> None:
    keypoints = openpose_copy(tmp_path / "kp", frames=60)
    out = tmp_path / "out"
    runs = []
    for seed in ("1", "2"):
        args = ["lift", "--keypoints", keypoints, "--cams", CALIB, *KEYPOINT_TIMING, *FAST, "--seed", seed]
        command = [sys.executable, "-m", "platypose", *map(str, args), "--formats", "npz,csv", "--out", str(out)]
        environment = {**os.environ, "OMP_NUM_THREADS": "1"}
        runs.append(
            subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment)
        )
    results = [(run.wait(timeout=400), *run.communicate()) for run in runs]
    codes = sorted(code for code, _, _ in results)
    busy = f"another platypose run is writing {out / 'cam01'}/ now; wait for it to end, or lift into another --out"
    assert codes == [0, 2], results  # one ran, the other refused (both start together: their lifts overlap)
    refused = next(err for code, _, err in results if code == 2)
    assert busy in refused and "Traceback" not in refused
    folder = out / "cam01"
    outputs, why = finished_outputs(folder, ("npz", "csv"))
    assert outputs is not None, why  # every file as lift.json recorded it
    done = platypose(["export", folder / "cam01.npz", "--formats", "csv", "--out", tmp_path / "again", "-q"], 120)
    assert done is not None and done.returncode == 0
    assert (tmp_path / "again/cam01.csv").read_bytes() == (folder / "cam01.csv").read_bytes()  # one run's CSV and npz
    entry = json.loads((out / "summary.json").read_text())["inputs"][0]
    assert entry["status"] == "ok"  # the refusal ends at once; the run that wrote the folder ends last


def hypotheses(npz: Path) -> int:
    with np.load(npz) as data:
        return data["hypotheses"].shape[1]


def test_resume_reruns_when_settings_change_and_says_why(run_cli, prior_file, tmp_path):
    source, out = openpose_copy(tmp_path, frames=12), tmp_path / "out"
    assert run_cli(*tiny_lift_args(prior_file, source, out, "--formats", "npz"))[0] == 0
    code, _, err = run_cli(*tiny_lift_args(prior_file, source, out, "--formats", "npz", "--resume"))
    assert code == 0
    entry = summary(out)["inputs"][0]
    assert entry["status"] == "skipped" and entry["reason"] == "finished earlier with the same inputs and settings"
    argv = tiny_lift_args(prior_file, source, out, "--formats", "npz", "--resume")
    argv[argv.index("--samples") + 1] = "4"
    code, _, _ = run_cli(*argv)
    assert code == 0 and summary(out)["inputs"][0]["status"] == "ok"
    assert hypotheses(out / "cam01/cam01.npz") == 4  # 2 were kept before the fix, with exit 0


def test_lift_json_is_output_relative_and_resume_works_from_elsewhere(run_cli, prior_file, tmp_path, monkeypatch):
    source = openpose_copy(tmp_path, frames=12).resolve()
    (tmp_path / "a").mkdir()
    monkeypatch.chdir(tmp_path / "a")
    assert run_cli(*tiny_lift_args(prior_file, source, Path("out"), "--formats", "npz"))[0] == 0
    manifest = json.loads((tmp_path / "a/out/cam01/lift.json").read_text())
    assert manifest["outputs"] == ["cam01.npz"] and len(manifest["fingerprint"]) == 64
    monkeypatch.chdir(tmp_path)
    shutil.move(tmp_path / "a", tmp_path / "b")
    monkeypatch.chdir(tmp_path / "b")
    assert run_cli(*tiny_lift_args(prior_file, source, Path("out"), "--formats", "npz", "--resume"))[0] == 0
    entry = summary(tmp_path / "b/out")["inputs"][0]
    assert entry["status"] == "skipped" and Path(entry["outputs"][0]).is_file()


def test_a_failed_rerun_keeps_the_good_run_and_its_log(run_cli, prior_file, tmp_path):
    source, out = openpose_copy(tmp_path, frames=12), tmp_path / "out"
    assert run_cli(*tiny_lift_args(prior_file, source, out, "--formats", "npz"))[0] == 0
    good_log, good_npz = (out / "cam01/log.txt").read_text(), (out / "cam01/cam01.npz").read_bytes()
    broken = sorted(source.glob("*.json"))[3]
    content = json.loads(broken.read_text())
    content["people"][0]["pose_keypoints_2d"][0] = 1e30
    broken.write_text(json.dumps(content))
    code, _, err = run_cli(*tiny_lift_args(prior_file, source, out, "--formats", "npz", "--resume"))
    assert code == 2 and "far outside" in err  # the input changed: run again, and it fails
    assert (out / "cam01/log.txt").read_text() == good_log
    assert (out / "cam01/cam01.npz").read_bytes() == good_npz
    assert "far outside" in (out / "cam01/log-failed.txt").read_text()
    assert summary(out)["inputs"][0]["error_kind"] == "input"


def test_transient_failures_are_retried_by_resume(run_cli, prior_file, tmp_path, monkeypatch):
    import platypose.exporters as exporters

    source, out = openpose_copy(tmp_path, frames=12), tmp_path / "out"
    real_export = exporters.export

    def full_disk(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(out / "cam01" / "cam01.npz"))

    monkeypatch.setattr(exporters, "export", full_disk)
    code, _, err = run_cli(*tiny_lift_args(prior_file, source, out, "--formats", "npz"))
    assert code == 1 and "No space left on device" in err  # not bad input: exit 1
    failure = json.loads((out / "cam01/failed.json").read_text())
    assert failure["transient"] is True and summary(out)["inputs"][0]["error_kind"] == "system"
    monkeypatch.setattr(exporters, "export", real_export)
    code, _, err = run_cli(*tiny_lift_args(prior_file, source, out, "--formats", "npz", "--resume"))
    assert code == 0 and summary(out)["inputs"][0]["status"] == "ok"


def test_stale_staging_and_stale_outputs_are_removed(run_cli, prior_file, tmp_path):
    source, out = openpose_copy(tmp_path, frames=12), tmp_path / "out"
    (out / "cam01").mkdir(parents=True)
    dead = out / ".cam01.999999999.abc.partial"  # a killed run's staging folder (no such process)
    dead.mkdir()
    (dead / ".hypotheses.npy").write_bytes(b"\0" * 1000)
    alive = out / f".cam01.{os.getpid()}.xyz.partial"  # a running process's: left alone
    alive.mkdir()
    (out / "cam01/cam01_p7.bvh").write_text("HIERARCHY\n")  # a person of an earlier run
    (out / "cam01/notes.txt").write_text("mine")  # not a platypose output: kept
    assert run_cli(*tiny_lift_args(prior_file, source, out, "--formats", "npz,bvh"))[0] == 0
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


def _lift_process(argv: list[str]) -> subprocess.Popen:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.Popen(
        [sys.executable, "-m", "platypose", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        preexec_fn=default_signals,
    )


def test_sigterm_removes_the_staging_folder(prior_file, tmp_path):
    source, out = openpose_copy(tmp_path, frames=100), tmp_path / "out"
    argv = tiny_lift_args(prior_file, source, out, "--formats", "npz")
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


def test_ctrl_c_with_two_jobs_keeps_finished_inputs(prior_file, tmp_path):
    out = tmp_path / "out"
    videos = [TAKE / f"cam0{i}.mp4" for i in (1, 2, 3, 4)]
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
