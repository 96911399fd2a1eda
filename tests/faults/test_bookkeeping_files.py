"""Damaged bookkeeping files in --out (lift.json, failed.json, summary.json) are set aside with one warning, and
locks and calibrations are opened only as regular files."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from audit_support import CALIB, FAST, KEYPOINT_TIMING, minimal_json, platypose

from platypose.cli.runs.batch import write_summary
from platypose.cli.runs.job import run_job
from platypose.cli.runs.jobs import Job, View
from platypose.cli.runs.outputs import finished_outputs
from platypose.cli.runs.records import earlier_failure
from platypose.cli.runs.settings import RunSettings

DEEP = "[" * 100_000 + "]" * 100_000  # json.loads: RecursionError


def _warnings(err: str, path: Path) -> list[str]:
    return [line for line in err.splitlines() if line.startswith(f"warning: {path}: damaged")]


@pytest.mark.parametrize(
    ("text", "why"),
    [
        (DEEP, "not valid JSON"),
        ('{"outputs": 5, "formats": ["npz"]}', "not the fields platypose writes"),
        ('{"outputs": ["a.npz"], "formats": [["npz"]]}', "not the fields platypose writes"),
        ("[1, 2]", "not the fields platypose writes"),
        ("\xff\xfe", "not valid JSON"),
    ],
)
def test_a_damaged_lift_json_is_set_aside_with_one_warning(tmp_path, capsys, text, why) -> None:
    manifest = tmp_path / "lift.json"
    manifest.write_text(text, encoding="latin-1")
    assert finished_outputs(tmp_path, ("npz",), "digest") == (None, "no lift.json of a finished earlier run")
    err = capsys.readouterr().err
    assert _warnings(err, manifest) == [f"warning: {manifest}: damaged ({why}); moved aside to lift.json.damaged"]
    assert not manifest.exists() and (tmp_path / "lift.json.damaged").read_bytes() == text.encode("latin-1")
    assert finished_outputs(tmp_path, ("npz",), "digest")[0] is None and capsys.readouterr().err == ""  # once


@pytest.mark.parametrize("text", [DEEP, '["error"]', '{"fingerprint": ["d"], "error": "x"}', '{"error": 5}'])
def test_a_damaged_failed_json_is_set_aside(tmp_path, capsys, text) -> None:
    (tmp_path / "failed.json").write_text(text)
    assert earlier_failure(tmp_path, "d") is None
    assert len(_warnings(capsys.readouterr().err, tmp_path / "failed.json")) == 1
    assert (tmp_path / "failed.json.damaged").is_file()


@pytest.mark.parametrize(
    "inputs",
    [5, [{"name": ["a", "b"], "status": "ok"}], [{"name": "a"}], [{"name": "a", "status": "gone"}], DEEP],
)
def test_a_damaged_summary_is_set_aside_and_the_new_one_written(tmp_path, capsys, inputs) -> None:
    summary = tmp_path / "summary.json"
    summary.write_text(inputs if isinstance(inputs, str) else json.dumps({"inputs": inputs}))
    mine = [{"input": "x.mp4", "name": "x", "status": "ok", "outputs": [], "seconds": 1.0, "error": None}]
    write_summary(tmp_path, mine, "start", {})
    assert json.loads(summary.read_text())["inputs"] == mine
    assert json.loads(summary.read_text())["counts"] == {"ok": 1, "failed": 0, "skipped": 0}
    assert len(_warnings(capsys.readouterr().err, summary)) == 1 and (tmp_path / "summary.json.damaged").is_file()


def test_a_second_writer_of_one_folder_refuses_and_writes_nothing(tmp_path) -> None:
    import fcntl

    out = tmp_path / "out"
    folder = out / "a"
    folder.mkdir(parents=True)
    missing = tmp_path / "a.mp4"  # the lift would fail at once: it must not even start
    job = Job("a", str(missing), (View("a", missing, missing),))
    with open(folder / ".lift.lock", "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX)  # another run writes OUT/a/ now
        entry = run_job(job, RunSettings(out=out))
    assert entry["status"] == "failed" and entry["error_kind"] == "input"
    assert (
        f"another platypose run is writing {folder}/ now; wait for it to end, or lift into another --out"
        in (entry["error"])
    )
    assert sorted(p.name for p in folder.iterdir()) == [".lift.lock"]  # no failed.json, no log of its own
    entry = run_job(job, RunSettings(out=out))  # free again: the run goes on (and fails on the missing video)
    assert entry["status"] == "failed" and "another platypose run" not in entry["error"]
    assert (folder / "failed.json").is_file()
    assert not (folder / ".lift.lock").exists()  # no empty lock file left in the output folder


def test_a_lock_file_goes_when_released_and_a_waiter_on_it_locks_anew(tmp_path) -> None:
    import threading

    from platypose.cli.runs.locks import Busy, exclusive_lock

    path = tmp_path / ".lift.lock"
    held, waiting, done = threading.Event(), threading.Event(), threading.Event()

    def wait_for_it() -> None:
        waiting.set()
        with exclusive_lock(path):  # blocks on the first holder's file, which is gone when it gets it
            held.set()
            done.wait(10)

    with exclusive_lock(path):
        waiter = threading.Thread(target=wait_for_it)
        waiter.start()
        waiting.wait(10)
        time.sleep(0.2)  # the waiter has opened the file and waits on its lock
    assert held.wait(10) and path.is_file()  # the waiter holds a new lock file
    with pytest.raises(Busy):
        with exclusive_lock(path, wait=False):
            pass
    done.set()
    waiter.join(10)
    assert not path.exists()


# ---------------------------------------------------------------------------- the real CLI, with a FIFO in the way


@pytest.mark.audit
def test_a_fifo_as_the_summary_lock_or_the_calibration_is_refused_at_once(tmp_path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / ".summary.lock")
    keypoints = minimal_json(tmp_path)
    done = platypose(["lift", "--keypoints", keypoints, "--cams", CALIB, *KEYPOINT_TIMING, *FAST, "--out", out], 120)
    assert done is not None, "lift blocked on the FIFO"
    assert done.returncode == 2 and done.stderr.strip().splitlines() == [
        f"error: {out / '.summary.lock'}: is a FIFO (named pipe), not a lock file platypose made; remove it"
    ]
    cams = tmp_path / "calib.toml"
    os.mkfifo(cams)
    writer = subprocess.Popen(  # an endless writer: the old reader took 1.9 GB, then MemoryError
        [
            sys.executable,
            "-c",
            f"import sys\nwith open({str(cams)!r}, 'wb') as f:\n  while True: f.write(b'#' * 65536)",
        ],
        stderr=subprocess.DEVNULL,
    )
    try:
        done = platypose(["calib", "check", cams], 60)
    finally:
        writer.kill()
        writer.wait()
    assert done is not None and done.returncode == 2
    assert done.stderr.strip() == f"error: {cams}: is a FIFO (named pipe), a regular calibration file was expected"


@pytest.mark.audit
def test_a_fifo_as_lift_json_is_set_aside_by_resume(tmp_path) -> None:
    out = tmp_path / "out"
    (out / "cam01").mkdir(parents=True)
    os.mkfifo(out / "cam01/lift.json")
    keypoints = minimal_json(tmp_path)
    args = ["lift", "--keypoints", keypoints, "--cams", CALIB, *KEYPOINT_TIMING, *FAST, "--out", out, "--resume"]
    started = time.monotonic()
    done = platypose([*args, "--formats", "npz"], 240)
    assert done is not None, f"blocked for {time.monotonic() - started:.0f} s"
    assert done.returncode == 0, done.stderr
    warning = f"warning: {out / 'cam01/lift.json'}: damaged (is a FIFO (named pipe), a regular bookkeeping file"
    assert sum(line.startswith(warning) for line in done.stderr.splitlines()) == 1, done.stderr
    assert json.loads((out / "cam01/lift.json").read_text())["outputs"] == ["cam01.npz"]


@pytest.mark.parametrize(
    ("flags", "said"),
    [(["person 0: flagged: spread"], ["person 0: flagged: spread"]), ([5], []), ("person 0", []), (None, [])],
)
def test_a_resumed_input_says_the_flags_its_lift_json_kept(tmp_path, flags, said) -> None:
    from platypose.cli.runs.records import earlier_flags

    manifest = {"outputs": ["a.npz"], "formats": ["npz"], **({"flags": flags} if flags is not None else {})}
    (tmp_path / "lift.json").write_text(json.dumps(manifest))
    assert earlier_flags(tmp_path) == said


def test_a_batch_whose_executor_refuses_to_start_leaves_no_summary(tmp_path) -> None:
    from platypose.cli.runs.batch import run_batch
    from platypose.lifting.errors import InputError

    def refuses(*_) -> None:
        raise InputError("--cpus-per-input 64: the largest Ray node has 2 CPU(s)")

    missing = tmp_path / "a.mp4"
    job = Job("a", str(missing), (View("a", missing, missing),))
    with pytest.raises(InputError):
        run_batch([job], RunSettings(out=tmp_path / "out"), executor=refuses)
    assert not (tmp_path / "out" / "summary.json").exists()
