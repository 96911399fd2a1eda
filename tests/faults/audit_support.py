"""Shared machinery of the bad-input audit cases (tests marked ``audit``): run the real CLI, classify the outcome.

Every case builds its input from the repository's real data (OpenPose JSON, videos, BVH, calibration)
corrupted in a temporary folder, runs ``platypose ...`` in a fresh process with a timeout, and is
classified as one of:

- ``clean error``: non-zero exit with a one-line ``error: ...`` (or a failed input named in the
  summary) that is not a Python exception's text and holds the case's words (``Run.says``: the file or option
  and the problem; a case expecting an error without them fails as ``unchecked message``);
- ``handled well``: the run succeeded and did what it should (e.g. warned about a truncated video);
- ``internal message``: an error whose text is a Python exception (``ZeroDivisionError: ...``, ``Aborted!``);
- ``wrong message``: a clean error line that lacks the words the case expects;
- ``traceback``; ``silent wrong`` (exit 0 where an error or a warning was due, or a wrong result);
- ``stale data`` (old outputs reported as current, or lost entries); ``hang`` (timeout);
- ``code execution`` (a marker file that a crafted input tries to create exists afterwards).

Only the first two pass. Cases needing root (a full or read-only tmpfs) are skipped elsewhere.
"""

from __future__ import annotations

import json
import os
import pickle
import re
import shutil
import signal
import subprocess
import sys
import uuid
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from media_helpers import truncated_copy

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "data"
TAKE = DATA / "video/pose2sim-balancing"
OPENPOSE = TAKE / "openpose-body25b"
CALIB = TAKE / "calib_pose2sim.toml"
BVH = DATA / "motion/mocapbank/test_mocapbank.bvh"
WALK = DATA / "motion/deepmimic/humanoid3d_walk.txt"
FAST = ["--samples", "4", "--steps", "4", "--skip", "1", "--guidance-iters", "2", "-q"]
KEYPOINT_TIMING = ["--fps", "60", "--image-size", "1920x1088"]
INTERNAL = re.compile(
    r"\b[A-Z][A-Za-z]*(Error|Exception|Warning)\b|Aborted|unpacking long long|object has no attribute"
)


@dataclass
class Run:
    """What one case runs: CLI arguments (or several runs), the words its error must hold, a check of the outcome,
    a marker file."""

    args: list | None = None
    expect: str = "error"  # error | ok
    check: Callable[[subprocess.CompletedProcess], str | None] | None = None
    marker: Path | None = None
    timeout: float = 180.0
    cwd: Path | None = None
    action: Callable[[], tuple[str, str]] | None = None  # a custom run: (outcome, note)
    skip: str | None = None
    says: tuple[str, ...] = ()  # an error's words, all in its error lines: the file or option, and the problem

    def __post_init__(self) -> None:
        assert not isinstance(self.says, str) and all(isinstance(w, str) for w in self.says), "says: a tuple of words"


@dataclass(frozen=True)
class Case:
    """One audit case: its name (the fault it checks) and what builds its run in a work folder."""

    name: str
    build: Callable[[Path], Run]


def registry(cases: list[Case]) -> Callable[[str], Callable]:
    """A decorator ``@case(name)`` adding the decorated builder to ``cases``."""

    def case(name: str) -> Callable:
        def register(build: Callable[[Path], Run]) -> Callable[[Path], Run]:
            cases.append(Case(name, build))
            return build

        return register

    return case


def check_case(case: Case, work: Path) -> None:
    """Build and run ``case`` in ``work``; fail unless the outcome is a clean error or handled well."""
    run = case.build(work)
    if run.skip:
        pytest.skip(run.skip)
    try:
        if run.action is not None:
            outcome, note = run.action()
        else:
            outcome, note = classify(run, platypose(run.args, run.timeout, run.cwd))
    finally:
        while MOUNTS:
            subprocess.run(["umount", "-l", str(MOUNTS.pop())], capture_output=True)
    assert outcome in ("clean error", "handled well"), f"{case.name}: {outcome}: {note}"


def default_signals() -> None:
    """Background shells start jobs with Ctrl-C ignored, and children inherit that: restore Python's handler."""
    signal.signal(signal.SIGINT, signal.default_int_handler)


def platypose(args: list, timeout: float, cwd: Path | None = None, env: dict | None = None):
    """Run the CLI in a fresh process; None on timeout."""
    environment = {**os.environ, "OMP_NUM_THREADS": "1", **(env or {})}
    command = [sys.executable, "-m", "platypose", *map(str, args)]
    try:
        return subprocess.run(command, capture_output=True, text=True, timeout=timeout, cwd=cwd, env=environment)
    except subprocess.TimeoutExpired:
        return None


def error_text(proc: subprocess.CompletedProcess) -> str:
    """The user-facing error lines of a failed run: 'error: ...' and lift's '  failed INPUT: ...'."""
    lines = [line for line in proc.stderr.splitlines() if line.startswith("error:") or line.startswith("  failed ")]
    return "\n".join(lines)


def classify(run: Run, proc: subprocess.CompletedProcess | None) -> tuple[str, str]:
    if proc is None:
        return "hang", f"no answer in {run.timeout:.0f} s"
    if run.marker is not None and run.marker.exists():
        return "code execution", f"{run.marker.name} was created"
    if "Traceback (most recent call last)" in proc.stderr:
        return "traceback", proc.stderr.strip().splitlines()[-1][:160]
    problem = run.check(proc) if run.check else None
    if run.expect == "error":
        if proc.returncode == 0:
            return "silent wrong", problem or "exit 0"
        text = error_text(proc)
        if not text or INTERNAL.search(text) or "Aborted" in proc.stderr:
            return "internal message", (text or proc.stderr.strip())[:160]
        if problem:
            return ("stale data" if problem.startswith("stale") else "silent wrong"), problem
        if not run.says:
            return "unchecked message", f"no words to look for in {text[:200]!r}"
        missing = [word for word in run.says if word not in text]
        if missing:
            return "wrong message", f"the error does not say {missing}: {text[:200]!r}"
        return "clean error", text.splitlines()[0][:160]
    if proc.returncode != 0:
        return "silent wrong", f"exit {proc.returncode}: {(error_text(proc) or proc.stderr.strip())[:160]}"
    if problem:
        return ("stale data" if problem.startswith("stale") else "silent wrong"), problem
    return "handled well", "ok"


# ---------------------------------------------------------------------------------------------- input makers


def openpose_copy(folder: Path, view: str = "cam01", frames: int = 20) -> Path:
    """The first ``frames`` real OpenPose files of ``view``, copied to ``folder/<view>_json``."""
    target = folder / f"{view}_json"
    target.mkdir(parents=True)
    for path in sorted((OPENPOSE / f"{view}_json").glob("*.json"))[:frames]:
        shutil.copy(path, target / path.name)
    return target


def edit_json(path: Path, change: Callable[[dict], None]) -> None:
    content = json.loads(path.read_text())
    change(content)
    path.write_text(json.dumps(content))


def minimal_json(folder: Path, count: int = 10, **override) -> Path:
    """The first ``count`` real cam01 OpenPose frames in the minimal JSON schema, as ``folder/cam01.json``."""
    frames = []
    for n, path in enumerate(sorted((OPENPOSE / "cam01_json").glob("*.json"))[:count]):
        people = json.loads(path.read_text())["people"]
        frames.append(
            {
                "frame": n,
                "people": [{"keypoints": np.reshape(p["pose_keypoints_2d"], (-1, 3)).tolist()} for p in people],
            }
        )
    content = {"format": "platypose-keypoints2d", "version": 1, "fps": 60.0, "image_size": [1920, 1088]}
    content.update(layout="body25b", frames=frames, **override)
    path = folder / "cam01.json"
    path.write_text(json.dumps(content))
    return path


def real_csv(folder: Path) -> Path:
    """Real cam01 keypoints written by ``platypose detect`` as our CSV."""
    source = openpose_copy(folder / "src")
    done = platypose(["detect", source, "--out", folder / "det", *KEYPOINT_TIMING, "-q"], 120)
    assert done is not None and done.returncode == 0, done and done.stderr
    return folder / "det/cam01/cam01_keypoints2d.csv"


def rewrite_csv(path: Path, change: Callable[[list[list[str]]], None]) -> Path:
    rows = [line.split(",") for line in path.read_text().splitlines()]
    change(rows)
    path.write_text("\n".join(",".join(r) for r in rows) + "\n")
    return path


def corrupt_bvh(folder: Path, value: str, frame: int = 3) -> Path:
    head, motion = BVH.read_text().split("MOTION", 1)
    lines = motion.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    values = lines[start + frame].split()
    values[0] = value
    lines[start + frame] = " ".join(values)
    path = folder / "broken.bvh"
    path.write_text(head + "MOTION" + "\n".join(lines) + "\n")
    return path


def truncated_video(folder: Path, keep: float = 0.6) -> Path:
    """cam01 of the bundled take cut to ``keep`` of its bytes."""
    return truncated_copy(TAKE / "cam01.mp4", folder / "cam01.mp4", keep)


def one_camera_calibration(folder: Path, camera: str) -> Path:
    """The Pose2Sim calibration reduced to one camera, converted to calib.json."""
    full = folder / "full.json"
    done = platypose(["calib", "convert", CALIB, "--out", full], 60)
    assert done is not None and done.returncode == 0, done and done.stderr
    content = json.loads(full.read_text())
    content["cameras"] = [c for c in content["cameras"] if c["name"] == camera]
    path = folder / f"only_{camera}.json"
    path.write_text(json.dumps(content))
    return path


def swapped_calibration(folder: Path) -> Path:
    """The Pose2Sim calibration with cam_01 and cam_02's poses exchanged (names kept)."""
    full = folder / "full.json"
    done = platypose(["calib", "convert", CALIB, "--out", full], 60)
    assert done is not None and done.returncode == 0, done and done.stderr
    content = json.loads(full.read_text())
    cams = {c["name"]: c for c in content["cameras"]}
    a, b = cams["cam_01"], cams["cam_02"]
    for key in set(a) - {"name", "size", "K", "dist"}:  # the poses (and anything else about placement)
        a[key], b[key] = b[key], a[key]
    path = folder / "swapped.json"
    path.write_text(json.dumps(content))
    return path


def tmpfs(folder: Path, size: str, read_only: bool = False) -> Path | None:
    """A small tmpfs (root only); None where mounting is not allowed."""
    mount = folder / f"fs-{uuid.uuid4().hex[:6]}"
    mount.mkdir()
    options = f"size={size}" + (",ro" if read_only else "")
    if subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(mount)], capture_output=True).returncode:
        return None
    MOUNTS.append(mount)
    return mount


MOUNTS: list[Path] = []


def fill(mount: Path) -> None:
    """Fill a tmpfs up to the last few kB."""
    with open(mount / "filler", "wb") as stream:
        try:
            while True:
                stream.write(b"\0" * 65536)
                stream.flush()
        except OSError:
            pass


def lift_args(keypoints: Path, out: Path, *extra) -> list:
    return ["lift", "--keypoints", keypoints, "--cams", CALIB, *KEYPOINT_TIMING, *FAST, "--out", out, *extra]


def tiny_lift_args(prior: str, keypoints: Path, out: Path, *extra) -> list[str]:
    """``lift`` of ``keypoints`` with the Pose2Sim calibration and the tiny test prior ``prior``: 2 hypotheses,
    3 steps, one thread, quiet."""
    fast = ["--samples", "2", "--steps", "3", "--skip", "1", "--guidance-iters", "1", "--threads", "1", "-q"]
    args = ["--keypoints", keypoints, "--cams", CALIB, "--prior", prior, *KEYPOINT_TIMING, *fast, "--out", out, *extra]
    return ["lift", *map(str, args)]


def summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


# ---------------------------------------------------------------------------------------------- the cases


class _RunsCode:
    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


def malicious_h36m(folder: Path) -> tuple[Path, Path]:
    marker = folder / "PWNED"
    stream = pickle.dumps(np.array({"S1": {"A": _RunsCode(str(marker))}}, dtype=object), protocol=4)
    import io

    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "|O", "fortran_order": False, "shape": ()})
    data = folder / "mocap" / "data_3d_h36m.npz"
    data.parent.mkdir()
    with zipfile.ZipFile(data, "w") as archive:
        archive.writestr("positions_3d.npy", header.getvalue() + stream)
    return data, marker


def result_npz(w: Path) -> Path:
    done = platypose(lift_args(openpose_copy(w / "kp"), w / "res", "--formats", "npz"), 240)
    assert done is not None and done.returncode == 0, done and done.stderr
    return w / "res/cam01/cam01.npz"
