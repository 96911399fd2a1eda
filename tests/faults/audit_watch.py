"""The audit machinery of whole runs (tests marked ``audit``): the installed ``platypose`` command in a child
process under a 3 GB address-space limit and a time limit, in a case folder that is watched.

A run is flagged for a write outside --out (a file created or changed in the case folder beside the out folder),
a hang (time limit), a memory blow-up (peak RSS over 2 GB, or MemoryError), a traceback, an internal exception
message (a Python exception name in the output or summary), or a silent wrong result (exit 0 where an error was
due, or a missing warning); it fails its test when flagged or when the exit code or message is not the one due.
"""

from __future__ import annotations

import io
import json
import os
import re
import resource
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
BIN = str(Path(sys.executable).parent / "platypose")
PY = sys.executable
TAKE = REPO / "data/video/pose2sim-balancing"
CALIB = REPO / "tests/data/calib"
PRIOR = REPO / "lifting/prior/weights/default.pt"
MEMORY_LIMIT = 3 * 2**30
BLOWUP_KB = 2 * 2**20  # 2 GB in ru_maxrss units
INTERNAL = re.compile(
    r"\b(TypeError|KeyError|AttributeError|IndexError|ZeroDivisionError|OverflowError|RecursionError|LinAlgError|"
    r"MemoryError|RuntimeError|AssertionError|UnpicklingError|NameError|UnboundLocalError)\b"
)
FLAGS = ("outside", "hang", "memory", "traceback", "internal", "silent")
LIFT = ["--samples", "2", "--quiet", "--threads", "1"]


def _limit() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    os.setsid()


def _snapshot(folder: Path, skip: Path) -> dict:
    return {
        str(p): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file() and skip not in p.parents and p != skip
    }


def watched(
    case: Path,
    args: list,
    expect: str,
    needle: str | tuple[str, ...] = "",
    timeout: float = 240,
    out: Path | None = None,
) -> dict:
    """Run ``platypose *args`` in ``case`` and return its row: the flags, exit code, seconds, peak MB and a note when
    the outcome is not the one due. ``expect``: "error" (exit 2, every ``needle`` on stderr), "ok" (exit 0), "warn"
    (exit 0, every ``needle`` in the output). An error or a warning names its words: the file or option, and the
    problem."""
    needles = (needle,) if isinstance(needle, str) else tuple(needle)
    assert expect == "ok" or all(n.strip() not in ("", "error:") for n in needles), "no words to look for"
    case.mkdir(parents=True, exist_ok=True)
    out = Path(out) if out else case / "out"
    before = _snapshot(case, out)
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    wrapper = [PY, "-c", (
        "import resource,subprocess,sys,json;"
        "p=subprocess.run(sys.argv[2:],capture_output=True,text=True,timeout=float(sys.argv[1]));"
        "print(json.dumps([p.returncode,p.stdout[-4000:],p.stderr[-4000:],"
        "resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss]))"
    ), str(timeout), BIN, *map(str, args)]  # fmt: skip
    started = time.monotonic()
    row = {"case": case.name, **{k: 0 for k in FLAGS}}
    try:
        done = subprocess.run(wrapper, capture_output=True, text=True, timeout=timeout + 30, cwd=case, env=env,
                              preexec_fn=_limit)  # fmt: skip
        code, stdout, stderr, rss = json.loads(done.stdout) if done.stdout.strip() else (None, "", done.stderr, 0)
    except (subprocess.TimeoutExpired, json.JSONDecodeError):
        code, stdout, stderr, rss = None, "", "", 0
    if (code is None and not stderr) or "TimeoutExpired" in (stderr or ""):
        row["hang"], stderr = 1, ""
    row["seconds"], row["code"], row["rss_mb"] = round(time.monotonic() - started, 1), code, round(rss / 1024)
    text = f"{stdout}\n{stderr}"
    row["memory"] = int(rss > BLOWUP_KB or "MemoryError" in text)
    row["traceback"] = int("Traceback (most recent call last)" in text)
    summaries = [p.read_text() for p in out.rglob("summary.json")] if out.is_dir() else []
    row["internal"] = int(bool(INTERNAL.search(text + "".join(summaries))))
    after = _snapshot(case, out)
    row["outside"] = int(any(p not in before or before[p] != t for p, t in after.items()))
    lines = [line for line in (stderr or "").strip().splitlines() if line.strip()]
    if not row["hang"]:
        if expect == "error" and not (code == 2 and lines and all(n in stderr for n in needles)):
            row["silent"] = int(code == 0)
            row["note"] = f"exit {code}: {(lines or [''])[-1][:160]}"
        elif expect == "ok" and code != 0:
            row["note"] = f"exit {code}: {(lines or [''])[-1][:160]}"
        elif expect == "warn" and not (code == 0 and all(n in text for n in needles)):
            row["silent"] = int(code == 0)
            row["note"] = f"exit {code}, no warning {needles!r}"
    return row


def check(
    case: Path,
    args: list,
    expect: str,
    needle: str | tuple[str, ...] = "",
    timeout: float = 240,
    out: Path | None = None,
) -> dict:
    """:func:`watched`, failing the test when the run is flagged or its outcome is not the one due."""
    row = watched(case, args, expect, needle, timeout, out)
    flagged = [k for k in FLAGS if row[k]]
    assert not flagged and "note" not in row, f"{row['case']}: {flagged} {row.get('note', '')}"
    return row


def npz_rewritten(source: Path, path: Path, **changes: bytes | np.ndarray) -> Path:
    """``source`` (an npz) copied to ``path`` with the members named in ``changes`` replaced (raw bytes or arrays)."""
    with zipfile.ZipFile(source) as a, zipfile.ZipFile(path, "w") as out:
        for info in a.infolist():
            key = info.filename[:-4]
            if key in changes:
                value = changes[key]
                if not isinstance(value, bytes):
                    buffer = io.BytesIO()
                    np.lib.format.write_array(buffer, value)
                    value = buffer.getvalue()
                out.writestr(info.filename, value)
            else:
                out.writestr(info.filename, a.read(info))
    return path
