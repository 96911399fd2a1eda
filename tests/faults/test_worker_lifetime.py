"""``lift --jobs``: workers end with their parent, even one killed with SIGKILL."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from audit_support import TAKE

pytestmark = pytest.mark.audit


def _children(pid: int) -> list[int]:
    found = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()
    return [int(p) for p in found]


def _alive(pids: list[int]) -> list[int]:
    alive = []
    for pid in pids:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            continue
        alive.append(pid)
    return alive


def test_workers_end_when_the_parent_is_killed(tmp_path) -> None:
    out = tmp_path / "out"
    command = [sys.executable, "-m", "platypose", "lift", TAKE / "cam01.mp4", TAKE / "cam02.mp4", "--jobs", "2"]
    command += ["--threads", "1", "-q", "--out", out, "--samples", "4", "--steps", "4"]
    parent = subprocess.Popen(list(map(str, command)), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and len(list(out.glob(".*.partial"))) < 2:
        time.sleep(0.2)  # until both workers lift (each has its staging folder)
    workers = _children(parent.pid)
    assert len(list(out.glob(".*.partial"))) == 2 and len(workers) >= 2
    parent.send_signal(signal.SIGKILL)
    parent.wait()
    deadline = time.monotonic() + 60
    while _alive(workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    left = _alive(workers)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert left == [], f"{len(left)} worker(s) still running 60 s after their parent was killed"
    assert list(out.glob(".*.partial")) == []  # each removed its staging folder on the way out


def test_a_worker_whose_parent_is_already_gone_ends_at_once() -> None:
    code = "import os, time\nfrom platypose.cli.runs.workers import end_with_parent\nend_with_parent(os.getppid() + 10**7, 0.01)\ntime.sleep(60)"
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert done.returncode == -signal.SIGTERM and time.monotonic() - started < 30
