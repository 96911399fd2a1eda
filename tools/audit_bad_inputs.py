"""Re-run the reliability audit of issue 17: bad inputs and faults against the real CLI, outcomes counted.

Every case builds its input from the repository's real data (OpenPose JSON, videos, BVH, calibration)
corrupted in a temporary folder, runs ``platypose ...`` in a fresh process with a timeout, and is
classified as one of:

- ``clean error``: non-zero exit with a one-line ``error: ...`` (or a failed input named in the
  summary) that is not a Python exception's text;
- ``handled well``: the run succeeded and did what it should (e.g. warned about a truncated video);
- ``internal message``: an error whose text is a Python exception (``ZeroDivisionError: ...``, ``Aborted!``);
- ``traceback``; ``silent wrong`` (exit 0 where an error or a warning was due, or a wrong result);
- ``stale data`` (old outputs reported as current, or lost entries); ``hang`` (timeout);
- ``code execution`` (a marker file that a crafted input tries to create exists afterwards).

Cases needing root (a full or read-only tmpfs) are skipped elsewhere.

    python tools/audit_bad_inputs.py                 # all cases, a table and the counts
    python tools/audit_bad_inputs.py --only resume,out-   # cases whose name contains "resume" or "out-"
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import uuid
import zipfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
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

OUTCOMES = (
    "clean error",
    "handled well",
    "internal message",
    "traceback",
    "silent wrong",
    "stale data",
    "hang",
    "code execution",
    "skipped",
)


@dataclass
class Run:
    """What one case runs: CLI arguments (or several runs), a check of the outcome, a marker file."""

    args: list | None = None
    expect: str = "error"  # error | ok
    check: Callable[[subprocess.CompletedProcess], str | None] | None = None
    marker: Path | None = None
    timeout: float = 180.0
    cwd: Path | None = None
    action: Callable[[], tuple[str, str]] | None = None  # a custom run: (outcome, note)
    skip: str | None = None


@dataclass
class Case:
    item: str
    name: str
    build: Callable[[Path], Run]
    outcome: str = ""
    note: str = ""
    seconds: float = 0.0
    extra: dict = field(default_factory=dict)


CASES: list[Case] = []


def case(item: str, name: str):
    def register(build: Callable[[Path], Run]) -> Callable[[Path], Run]:
        CASES.append(Case(item, name, build))
        return build

    return register


def _default_signals() -> None:
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


def minimal_json(folder: Path, **override) -> Path:
    """Real cam01 OpenPose frames in the minimal JSON schema."""
    frames = []
    for n, path in enumerate(sorted((OPENPOSE / "cam01_json").glob("*.json"))[:10]):
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
    import av

    target = folder / "cam01.mp4"
    with av.open(str(TAKE / "cam01.mp4")) as inp, av.open(str(target), "w", options={"movflags": "faststart"}) as out:
        stream = out.add_stream_from_template(inp.streams.video[0])
        for packet in inp.demux(inp.streams.video[0]):
            if packet.dts is not None:
                packet.stream = stream
                out.mux(packet)
    data = target.read_bytes()
    target.write_bytes(data[: int(len(data) * keep)])
    return target


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


@case("1", "h36m-malicious-motion-info")
def _(w: Path) -> Run:
    data, marker = malicious_h36m(w)
    return Run(["motion", "info", data], marker=marker)


@case("1", "h36m-malicious-train-folder-scan")
def _(w: Path) -> Run:
    data, marker = malicious_h36m(w)
    return Run(["train", data.parent, "--out", w / "p.pt", "--iterations", "1"], marker=marker)


@case("1", "h36m-malicious-eval")
def _(w: Path) -> Run:
    data, marker = malicious_h36m(w)
    return Run(["eval", data, "--frames", "1", "--samples", "2"], marker=marker)


def _result_npz(w: Path) -> Path:
    done = platypose(lift_args(openpose_copy(w / "kp"), w / "res", "--formats", "npz"), 240)
    assert done is not None and done.returncode == 0, done and done.stderr
    return w / "res/cam01/cam01.npz"


@case("2", "rrd-disk-full-x3")
def _(w: Path) -> Run:
    mount = tmpfs(w, "1m")
    if mount is None:
        return Run(skip="cannot mount a tmpfs")
    npz = _result_npz(w)

    def action() -> tuple[str, str]:
        notes = []
        for _ in range(3):
            proc = platypose(
                ["export", npz, "--formats", "rrd", "--out", mount, "--video", f"cam_01={TAKE / 'cam04.mp4'}"], 120
            )
            outcome, note = classify(Run(timeout=120), proc)
            if outcome != "clean error":
                return outcome, note
            notes.append(note)
            if any(p.name.endswith(".tmp") or p.suffix == ".rrd" for p in mount.iterdir()):
                return "silent wrong", "a partial recording was left"
        return "clean error", notes[0]

    return Run(action=action)


@case("3", "openpose-misnumbered-file")
def _(w: Path) -> Run:
    folder = openpose_copy(w, frames=4)
    (folder / "cam01.0003.json").rename(folder / "cam01.99999999.json")
    return Run(["detect", folder, "--out", w / "out", *KEYPOINT_TIMING, "-q"], timeout=60)


def _resume_setup(w: Path, samples: str) -> tuple[Path, Path]:
    keypoints = openpose_copy(w / "kp")
    out = w / "out"
    done = platypose([*lift_args(keypoints, out), "--samples", samples, "--formats", "npz"], 240)
    assert done is not None and done.returncode == 0, done and done.stderr
    return keypoints, out


@case("4", "resume-after-settings-changed")
def _(w: Path) -> Run:
    keypoints, out = _resume_setup(w, "2")

    def check(proc) -> str | None:
        with np.load(out / "cam01/cam01.npz", allow_pickle=False) as data:
            count = data["hypotheses"].shape[1]
        return None if count == 4 else f"stale: {count} hypotheses kept, 4 asked"

    return Run([*lift_args(keypoints, out), "--samples", "4", "--formats", "npz", "--resume"], "ok", check)


@case("4", "resume-from-another-working-directory")
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


@case("4", "failed-rerun-keeps-the-good-log")
def _(w: Path) -> Run:
    keypoints, out = _resume_setup(w, "4")
    good = (out / "cam01/log.txt").read_text()
    edit_json(sorted(keypoints.glob("*.json"))[2], lambda c: c["people"][0]["pose_keypoints_2d"].__setitem__(0, 1e30))

    def check(proc) -> str | None:
        if (out / "cam01/log.txt").read_text() != good:
            return "stale: the good run's log.txt was overwritten by the failed run"
        return None

    return Run([*lift_args(keypoints, out), "--formats", "npz"], "error", check)


@case("5", "one-camera-calibration-for-another-view")
def _(w: Path) -> Run:
    calib = one_camera_calibration(w, "cam_01")
    keypoints = openpose_copy(w / "kp", "cam02")
    return Run(["lift", "--keypoints", keypoints, "--cams", calib, *KEYPOINT_TIMING, *FAST, "--out", w / "out"])


@case("6", "bvh-1e308-motion-info")
def _(w: Path) -> Run:
    return Run(["motion", "info", corrupt_bvh(w, "1e308")])


@case("6", "bvh-1e308-train")
def _(w: Path) -> Run:
    out = w / "p.pt"
    return Run(
        ["train", corrupt_bvh(w, "1e308"), "--out", out, "--iterations", "2"],
        check=lambda proc: "a prior was written" if out.exists() else None,
    )


@case("6", "prior-with-nan-weights-prior-info")
def _(w: Path) -> Run:
    import torch

    payload = torch.load(REPO / "lifting/priors/default.pt", weights_only=True)
    first = next(iter(payload["state_dict"]))
    payload["state_dict"][first] = payload["state_dict"][first] * float("nan")
    torch.save(payload, w / "nan.pt")
    return Run(["prior-info", w / "nan.pt"])


def _out_cases() -> None:
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
        "export": lambda w, out: ["export", _result_npz(w), "--formats", "csv,bvh", "--out", out],
    }
    for command, make in commands.items():
        for kind, where in kinds.items():
            file_output = command in ("calib-convert", "train")
            if kind == ("is-a-file" if file_output else "is-a-folder"):
                continue  # a file output may replace a file; a folder output may be an existing folder

            def build(w: Path, make=make, where=where) -> Run:
                out = where(w)
                if out is None:
                    return Run(skip="cannot mount a tmpfs")
                return Run(make(w, out))

            CASES.append(Case("7", f"out-{kind}-{command}", build))


def _file(w: Path) -> Path:
    (w / "afile").write_text("x")
    return w / "afile"


def _full(w: Path) -> Path | None:
    mount = tmpfs(w, "512k")
    if mount is not None:
        fill(mount)
    return mount


_out_cases()


@case("8", "sigterm-leaves-no-staging")
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


@case("9", "swapped-calibrations")
def _(w: Path) -> Run:
    calib = swapped_calibration(w)
    kp = w / "kp"
    for view in ("cam01", "cam02"):
        openpose_copy(kp, view, frames=20)
    out = w / "out"

    def check(proc) -> str | None:
        entries = summary(out)["inputs"]
        warned = any(
            "cam_01" in " ".join(e.get("warnings", [])) or "cam_02" in " ".join(e.get("warnings", [])) for e in entries
        )
        if not warned:
            return "no warning naming the swapped view in summary.json"
        if "warning" not in proc.stderr:
            return "no warning on the console"
        return None

    args = ["lift", "--keypoints", kp, "--cams", calib, *KEYPOINT_TIMING, *FAST[:-1], "--out", out, "--formats", "npz"]
    return Run(args, "ok", check)


@case("10", "truncated-video-detect")
def _(w: Path) -> Run:
    video = truncated_video(w)
    return Run(
        ["detect", video, "--out", w / "out", "--stride", "10", "-q", "--threads", "1"],
        "ok",
        lambda proc: None if "could be decoded" in proc.stderr else "no warning about the truncated video",
    )


@case("10", "truncated-video-lift")
def _(w: Path) -> Run:
    video = truncated_video(w)
    out = w / "out"

    def check(proc) -> str | None:
        entry = summary(out)["inputs"][0]
        if "could be decoded" not in " ".join(entry.get("warnings", [])):
            return "summary.json does not say the video is truncated"
        return None if "could be decoded" in proc.stderr else "no warning on the console"

    return Run(
        ["lift", video, *FAST, "--stride", "10", "--formats", "npz", "--out", out, "--threads", "1"], "ok", check
    )


@case("11", "concurrent-lifts-one-out")
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


@case("11", "stale-person-bvh-from-an-earlier-run")
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


@case("11", "jobs-2-ctrl-c")
def _(w: Path) -> Run:
    out = w / "out"
    inputs = [TAKE / f"cam0{i}.mp4" for i in (1, 2, 3, 4)]  # four one-view inputs, detected every 20th frame

    def action() -> tuple[str, str]:
        env = {**os.environ, "OMP_NUM_THREADS": "1"}
        command = [sys.executable, "-m", "platypose", "lift", *map(str, inputs), *FAST, "--stride", "20", "--jobs", "2"]
        command += ["--formats", "npz", "--out", str(out)]
        process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, preexec_fn=_default_signals
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


@case("11", "json-image-size-0")
def _(w: Path) -> Run:
    return Run(["detect", minimal_json(w, image_size=[0, 0]), "--out", w / "out", "-q"])


@case("11", "lift-json-image-size-0")
def _(w: Path) -> Run:
    return Run(["lift", "--keypoints", minimal_json(w, image_size=[0, 0]), *FAST, "--out", w / "out"])


@case("11", "openpose-keypoint-1e30")
def _(w: Path) -> Run:
    folder = openpose_copy(w)
    edit_json(folder / "cam01.0002.json", lambda c: c["people"][0]["pose_keypoints_2d"].__setitem__(0, 1e30))
    return Run(lift_args(folder, w / "out"))


@case("11", "openpose-keypoints-far-outside-the-image")
def _(w: Path) -> Run:
    folder = openpose_copy(w)
    edit_json(folder / "cam01.0002.json", lambda c: c["people"][0]["pose_keypoints_2d"].__setitem__(1, -50000.0))
    return Run(["detect", folder, "--out", w / "out", *KEYPOINT_TIMING, "-q"])


@case("11", "csv-zero-frame-times")
def _(w: Path) -> Run:
    path = rewrite_csv(real_csv(w), lambda rows: [r.__setitem__(2, "0.000000") for r in rows[1:]])
    return Run(["lift", "--keypoints", path, "--image-size", "1920x1088", *FAST, "--out", w / "out"])


@case("11", "csv-short-row")
def _(w: Path) -> Run:
    path = rewrite_csv(real_csv(w), lambda rows: rows.__setitem__(5, rows[5][:4]))
    return Run(["detect", path, "--image-size", "1920x1088", "--out", w / "out", "-q"])


@case("11", "detect-fps-inf")
def _(w: Path) -> Run:
    return Run(["detect", openpose_copy(w), "--fps", "inf", "--image-size", "1920x1088", "--out", w / "out", "-q"])


@case("11", "lift-fps-inf")
def _(w: Path) -> Run:
    return Run(
        [
            "lift",
            "--keypoints",
            openpose_copy(w),
            "--fps",
            "inf",
            "--image-size",
            "1920x1088",
            *FAST,
            "--out",
            w / "out",
        ]
    )


@case("11", "lift-seed-1e23")
def _(w: Path) -> Run:
    return Run([*lift_args(openpose_copy(w), w / "out"), "--seed", str(10**23)])


@case("11", "lift-samples-1e9")
def _(w: Path) -> Run:
    return Run([*lift_args(openpose_copy(w), w / "out"), "--samples", str(10**9)])


@case("11", "lift-long-file-name")
def _(w: Path) -> Run:
    folder = openpose_copy(w)
    long = folder.rename(w / ("x" * 240 + "_json"))
    args = ["lift", "--keypoints", long, *KEYPOINT_TIMING, *FAST, "--out", w / "out", "--formats", "npz,csv,bvh"]
    return Run(args, "ok")  # no --cams: a view named x...x matches no camera of the Pose2Sim calibration


@case("11", "zero-byte-npz-detect")
def _(w: Path) -> Run:
    (w / "cam01_keypoints2d.npz").write_bytes(b"")
    return Run(["detect", w / "cam01_keypoints2d.npz", "--out", w / "out", "-q"])


@case("11", "zero-byte-npz-info")
def _(w: Path) -> Run:
    (w / "clip.npz").write_bytes(b"")
    return Run(["info", w / "clip.npz"])


for _options in (["--max-frames", "0"], ["--fps", "0"], ["--width", "10", "--heads", "3"], ["--learning-rate", "nan"]):

    def _build(w: Path, options=_options) -> Run:
        return Run(["train", WALK, "--out", w / "p.pt", "--iterations", "2", *options])

    CASES.append(Case("11", "train" + "".join(o if o.startswith("--") else f"-{o}" for o in _options), _build))


@case("11", "600-people-per-frame")
def _(w: Path) -> Run:
    folder = openpose_copy(w, frames=4)
    edit_json(folder / "cam01.0001.json", lambda c: c.__setitem__("people", c["people"][:1] * 600))
    return Run(["detect", folder, "--out", w / "out", *KEYPOINT_TIMING, "-q"], timeout=120)


@case("11", "fractional-frame-numbers")
def _(w: Path) -> Run:
    path = minimal_json(w)
    edit_json(path, lambda c: c["frames"][1].__setitem__("frame", 1.5))
    return Run(["detect", path, "--out", w / "out", "-q"])


@case("11", "lift-exit-code-for-bad-per-input-value")
def _(w: Path) -> Run:
    folder = openpose_copy(w)
    edit_json(folder / "cam01.0002.json", lambda c: c["people"][0]["pose_keypoints_2d"].__setitem__(0, 1e30))
    return Run(
        lift_args(folder, w / "out"),
        check=lambda proc: None if proc.returncode == 2 else f"exit {proc.returncode}, README promises 2",
    )


@case("11", "lift-help-keeps-bracketed-defaults")
def _(w: Path) -> Run:
    def check(proc) -> str | None:
        shown = " ".join(proc.stdout.split())
        missing = [b for b in ("[default: (50)]", "[default: (l2)]", "[default: out]") if b not in shown]
        return f"--help lost {missing}" if missing else None

    return Run(["lift", "--help"], "ok", check)


@case("11", "detect-takes-q")
def _(w: Path) -> Run:
    return Run(["detect", openpose_copy(w, frames=4), "--out", w / "out", *KEYPOINT_TIMING, "-q"], "ok")


@case("11", "quiet-means-quiet")
def _(w: Path) -> Run:
    video = truncated_video(w)

    def check(proc) -> str | None:
        noise = [line for line in proc.stderr.splitlines() if line.strip() and not line.startswith("warning:")]
        return f"stderr with -q: {noise[:2]}" if noise else None

    return Run(["detect", video, "--out", w / "out", "--stride", "10", "-q", "--threads", "1"], "ok", check)


# ---------------------------------------------------------------------------------------------- main


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="", help="run the cases whose name contains one of these (comma-separated)")
    parser.add_argument("--json", type=Path, help="also write the outcomes as JSON here")
    options = parser.parse_args()
    wanted = options.only.split(",")
    chosen = [c for c in CASES if any(w in c.name for w in wanted)]
    root = Path(tempfile.mkdtemp(prefix="platypose-audit-"))
    try:
        for number, item in enumerate(chosen):
            work = root / f"{number:02d}-{item.name}"
            work.mkdir()
            started = time.monotonic()
            try:
                run = item.build(work)
                if run.skip:
                    item.outcome, item.note = "skipped", run.skip
                elif run.action is not None:
                    item.outcome, item.note = run.action()
                else:
                    item.outcome, item.note = classify(run, platypose(run.args, run.timeout, run.cwd))
            except Exception as err:  # a broken case is reported, the audit goes on
                item.outcome, item.note = "skipped", f"case could not run: {type(err).__name__}: {err}"
            item.seconds = time.monotonic() - started
            print(f"{item.item:>3} {item.name:45s} {item.outcome:17s} {item.seconds:6.1f} s  {item.note}", flush=True)
    finally:
        for mount in MOUNTS:
            subprocess.run(["umount", "-l", str(mount)], capture_output=True)
        shutil.rmtree(root, ignore_errors=True)
    counts = Counter(c.outcome for c in chosen)
    print("\n" + ", ".join(f"{counts.get(o, 0)} {o}" for o in OUTCOMES) + f" ({len(chosen)} cases)")
    if options.json:
        rows = [
            {"item": c.item, "name": c.name, "outcome": c.outcome, "note": c.note, "seconds": round(c.seconds, 1)}
            for c in chosen
        ]
        options.json.write_text(json.dumps({"cases": rows, "counts": dict(counts)}, indent=1) + "\n")


if __name__ == "__main__":
    main()
