"""``export`` and the OpenSim format, run as the real CLI: --name stays
inside --out, SIGTERM leaves no temporary file, a full temporary disk and a missing opensim package each give one
line, and OpenSim's model summaries stay off the console."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from audit_support import CALIB, FAST, KEYPOINT_TIMING, minimal_json, platypose, result_npz, tmpfs

pytestmark = pytest.mark.audit


@pytest.fixture(scope="module")
def npz(tmp_path_factory) -> Path:
    """A real result: 20 frames of two people, lifted from the Pose2Sim take's OpenPose keypoints."""
    return result_npz(tmp_path_factory.mktemp("result"))


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_export_name_is_made_a_safe_file_name_inside_out(npz, tmp_path) -> None:
    out = tmp_path / "o/out"
    done = platypose(["export", npz, "--formats", "csv", "--name", "../../esc", "--out", out, "-q"], 120)
    assert done is not None and done.returncode == 0, done and done.stderr
    assert done.stderr.strip() == "--name ../../esc: not a plain file name; the files are named ___.._esc"
    assert _files(tmp_path) == [
        "o",
        "o/out",
        *(f"o/out/___.._esc{end}" for end in (".csv", "_gaps.json")),
    ]
    done = platypose(["export", npz, "--formats", "csv", "--name", "a/b", "--out", out, "-q"], 120)
    assert done is not None and done.returncode == 0 and not (out / "a").exists()
    assert (out / "a_b.csv").is_file()


def test_mot_keeps_opensims_model_summaries_off_the_console(npz, tmp_path) -> None:
    pytest.importorskip("opensim")
    done = platypose(["export", npz, "--formats", "mot", "--out", tmp_path, "-q"], 300)
    assert done is not None and done.returncode == 0, done and done.stderr
    assert "MODEL:" not in done.stdout + done.stderr
    lines = done.stdout.splitlines()  # the files written, one a line, and nothing else
    assert sorted(lines) == sorted(str(p) for p in tmp_path.iterdir()) and any(n.endswith("_p0.mot") for n in lines)


def test_sigterm_during_export_leaves_no_temporary_file(npz, tmp_path) -> None:
    pytest.importorskip("opensim")
    scratch, out = tmp_path / "tmp", tmp_path / "out"
    scratch.mkdir()
    command = [sys.executable, "-m", "platypose", "export", npz, "--formats", "mot,csv", "--out", out, "-q"]
    environment = {**os.environ, "TMPDIR": str(scratch), "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen(command, env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not any(scratch.iterdir()) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)  # until OpenSim works in its temporary folder
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == (
        "interrupted; no file was left half-written (those finished before are new, the rest as they were)"
    )
    assert list(scratch.iterdir()) == []  # OpenSim's temporary folder is gone
    assert not [p for p in (out.iterdir() if out.exists() else []) if p.name.startswith(".")]


def test_mot_on_a_full_temporary_disk_is_one_line(npz, tmp_path) -> None:
    pytest.importorskip("opensim")
    mount = tmpfs(tmp_path, "256k")
    if mount is None:
        pytest.skip("cannot mount a tmpfs")
    free = os.statvfs(mount).f_bavail * os.statvfs(mount).f_frsize
    (mount / "filler").write_bytes(b"\0" * (free - 20 * 1024))  # room for a test file, not for OpenSim's
    try:
        done = platypose(
            ["export", npz, "--formats", "mot", "--out", tmp_path / "out"], 300, env={"TMPDIR": str(mount)}
        )
    finally:
        subprocess.run(["umount", "-l", str(mount)], capture_output=True)
    assert done is not None and done.returncode == 2 and "Traceback" not in done.stderr, done and done.stderr
    lines = done.stderr.strip().splitlines()
    assert lines[-1].startswith(f"error: {mount}/platypose-opensim-") and lines[-1].endswith(
        ": no space left for OpenSim's temporary files (set TMPDIR)"
    ), done.stderr


def test_lift_refuses_mot_without_opensim_before_detecting(tmp_path) -> None:
    out = tmp_path / "out"
    hide = "import sys; sys.modules['opensim'] = None; sys.argv[0] = 'platypose'; from platypose.cli.app import main; main()"
    args = ["lift", "--keypoints", minimal_json(tmp_path), "--cams", CALIB, *KEYPOINT_TIMING, *FAST]
    done = subprocess.run(
        [sys.executable, "-c", hide, *map(str, args), "--formats", "npz,mot", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip() == (
        "error: --formats: mot needs the opensim package; install it with pip install 'platypose[opensim]'"
    )
    assert not (out / "cam01").exists() and not (out / "summary.json").exists()  # nothing detected, nothing run
