"""Audit, whole runs: job names inside --out, Ray addresses that are no cluster, --resume after changes,
sync and swapped views, names matching no camera, mixed frame rates; each run ends as due, unflagged
(:mod:`audit_watch`). Run with ``pytest -m audit``."""

from __future__ import annotations

import json
import shutil
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from audit_watch import LIFT, REPO, TAKE, check

pytestmark = pytest.mark.audit

CALIB = TAKE / "calib_pose2sim.toml"
SSH_GREETING = b"SSH-2.0-OpenSSH_9.6\r\n"
TIMING = ["--fps", "60", "--image-size", "1920x1088"]  # keypoint files with no video beside them


def test_job_names_stay_inside_out(batch_folder, tmp_path: Path) -> None:
    names = tmp_path / "in"
    names.mkdir()
    for n in ("...mp4", "..mp4", ".hidden.mp4", "summary.json.mp4", "a\nerror: forged.mp4", "x" * 240 + ".mp4"):
        shutil.copy(batch_folder / "good.mp4", names / n)
    out = tmp_path / "out"
    check(tmp_path, ["lift", names, "--out", out, "--formats", "npz,bvh", *LIFT], "ok", out=out)


def _server(reply: bytes) -> int:
    """A port on localhost answering every connection with ``reply`` (a server that is not Ray)."""
    listener = socket.create_server(("127.0.0.1", 0))

    def serve():
        while True:
            conn, _ = listener.accept()
            try:
                conn.recv(64)
                conn.sendall(reply)
            finally:
                conn.close()

    threading.Thread(target=serve, daemon=True).start()
    return listener.getsockname()[1]


def _closed_port() -> int:
    with socket.create_server(("127.0.0.1", 0)) as probe:
        return probe.getsockname()[1]


@pytest.mark.parametrize(
    ("address", "needle"),
    [
        (lambda: f"127.0.0.1:{_closed_port()}", "nothing answers"),
        (lambda: "nonsense", "not an address"),
        (lambda: f"ray://127.0.0.1:{_closed_port()}", "nothing answers"),
        (lambda: f"127.0.0.1:{_server(SSH_GREETING)}", "not as a Ray cluster"),
        (lambda: "no-such-host.invalid:6379", "nothing answers"),
        (lambda: "127.0.0.1:0", "not an address"),
    ],
    ids=["closed-port", "nonsense", "ray-client-closed", "ssh-server", "unresolvable", "port-0"],
)
def test_ray_addresses_that_are_no_cluster(batch_folder, tmp_path: Path, address, needle: str) -> None:
    args = ["lift", batch_folder / "good.mp4", "--executor", "ray", "--ray-address", address(), *LIFT]
    check(tmp_path, args, "error", ("--ray-address", needle), timeout=90)


def _skipped(out: Path) -> int:
    return json.loads((out / "summary.json").read_text())["counts"]["skipped"]


def test_resume_redoes_what_changed(batch_folder, tmp_path: Path) -> None:
    out = tmp_path / "out"
    base = ["lift", batch_folder / "good.mp4", "--out", out, "--formats", "npz,bvh", *LIFT]
    check(tmp_path / "first", base, "ok", out=out)
    bvh = out / "good/good_p0.bvh"
    text = bvh.read_text()
    bvh.write_text(text[:-2] + ("1" if text[-2] != "1" else "2") + text[-1])
    (out / ".good.999999999.x.partial").mkdir()
    check(tmp_path / "changed-output", [*base, "--resume"], "ok", out=out)
    assert not _skipped(out), "a changed output was skipped"
    assert not list(out.glob(".good.*.partial")), "a stale staging folder was left"
    check(tmp_path / "runtime", [*base, "--resume", "--runtime", "float32"], "ok", out=out)
    assert not _skipped(out), "a run with another runtime was skipped"


def test_resume_sees_keypoints_copied_with_an_old_time(tmp_path: Path) -> None:
    views = tmp_path / "kp/cam01_json"
    shutil.copytree(TAKE / "openpose-body25b/cam01_json", views)
    out = tmp_path / "out"
    base = ["lift", "--keypoints", views, *TIMING, "--out", out, "--formats", "npz", *LIFT]
    check(tmp_path / "first", base, "ok", out=out)
    files = sorted(views.iterdir())
    shutil.copy2(files[-1], files[len(files) // 2])
    check(tmp_path / "again", [*base, "--resume"], "ok", out=out)
    assert not _skipped(out), "keypoints copied with an old time were skipped"


def test_a_broken_sync_file_with_one_view(tmp_path: Path) -> None:
    (tmp_path / "broken.json").write_text("{oops")
    args = ["lift", "--keypoints", TAKE / "openpose-body25b/cam01_json", "--fps", "60", "--cams", CALIB, "--sync"]
    check(tmp_path / "case", [*args, tmp_path / "broken.json", *LIFT], "error", ("broken.json", "not valid JSON"))


def _views(folder: Path, frames: slice, still: str = "") -> Path:
    """The take's four OpenPose views, ``frames`` of each; view ``still`` repeats its first frame throughout."""
    for view in sorted((TAKE / "openpose-body25b").iterdir()):
        files = sorted(view.glob("*.json"))[frames]
        (folder / view.name).mkdir(parents=True)
        for i, f in enumerate(files):
            source = files[0] if view.name == still else f
            (folder / view.name / f"{view.name[:-5]}.{i:04d}.json").write_bytes(source.read_bytes())
    return folder


@pytest.mark.parametrize(
    ("frames", "still", "needle"),
    [(slice(None), "cam02_json", "barely moves"), (slice(60), "", "s of frames")],
    ids=["still-view", "one-second"],
)
def test_sync_auto_warns_when_it_cannot_tell(tmp_path: Path, frames: slice, still: str, needle: str) -> None:
    views = _views(tmp_path / "kp", frames, still)
    args = ["calib", "check", CALIB, "--keypoints", views, "--fps", "60", "--sync", "auto"]
    check(tmp_path / "case", args, "warn", needle)


def test_views_at_60_and_30_fps_are_refused(data_dir, tmp_path: Path) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    code = (
        "import sys; from pathlib import Path; sys.path.insert(0, 'tests'); import conftest;"
        "from platypose.detectors.sources.video import iter_frames;"
        "take, out = Path(sys.argv[1]), Path(sys.argv[2]);"
        "conftest._write_clip(out / 'cam02.mp4', [f for _, f in iter_frames(take / 'cam02.mp4', max_frames=12)], 30.0);"
        "conftest._write_clip(out / 'cam01.mp4', [f for _, f in iter_frames(take / 'cam01.mp4', max_frames=24)], 60.0)"
    )
    subprocess.run([sys.executable, "-c", code, str(TAKE), str(folder)], cwd=REPO, check=True)
    out = tmp_path / "out"
    check(
        tmp_path / "case",
        ["lift", folder, "--cams", CALIB, "--out", out, *LIFT],
        "error",
        ("cam01.mp4", "different frame rates (60, 30 fps)"),
        out=out,
    )


def test_swapped_views_are_warned_about(tmp_path: Path) -> None:
    views = tmp_path / "kp"
    for src, dst in (("cam01", "cam03"), ("cam02", "cam02"), ("cam03", "cam01"), ("cam04", "cam04")):
        (views / f"{dst}_json").mkdir(parents=True)
        for f in sorted((TAKE / "openpose-body25b" / f"{src}_json").glob("*.json")):
            (views / f"{dst}_json" / f.name.replace(src, dst)).write_bytes(f.read_bytes())
    out = tmp_path / "out"
    args = ["lift", "--keypoints", views, "--cams", CALIB, *TIMING, "--out", out, "--formats", "npz", *LIFT]
    check(tmp_path / "case", args, "warn", "swapped", out=out)


def test_video_names_matching_no_camera(batch_folder, tmp_path: Path) -> None:
    names = tmp_path / "in"
    names.mkdir()
    for n in ("front", "side", "back", "top"):
        shutil.copy(batch_folder / "good.mp4", names / f"{n}.mp4")
    out = tmp_path / "out"
    check(
        tmp_path,
        ["lift", names, "--cams", CALIB, "--out", out, *LIFT],
        "error",
        ("no camera matches a view by name", "name each video"),
        out=out,
    )
