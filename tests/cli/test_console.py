"""The end of a lift's console output: the files written and how to open the recording."""

from __future__ import annotations

import shlex
import subprocess
import sys

from platypose.cli.terminal.console import FFMPEG_NOTE, LISTED_INPUTS, written_lines


def test_lift_lists_the_files_it_wrote_and_the_command_to_open_the_recording(tmp_path, monkeypatch):
    folder = tmp_path / "take"
    ok = {"name": "take", "status": "ok", "outputs": [str(folder / "take.npz"), str(folder / "take.rrd")]}
    failed = {"name": "bad", "status": "failed", "outputs": []}
    monkeypatch.setattr("shutil.which", lambda name: f"/usr/bin/{name}")
    assert written_lines([ok, failed]) == [
        f"take: wrote take.npz, take.rrd in {folder}/",
        f"  look at it: {sys.executable} -m rerun {folder / 'take.rrd'}",
    ]
    many = [{**ok, "name": f"t{i}"} for i in range(LISTED_INPUTS + 1)]
    assert written_lines(many)[0] == f"t0: 2 files in {folder}/" and len(written_lines(many)) == LISTED_INPUTS + 1


def test_the_printed_command_opens_the_recording_from_a_new_shell_and_names_ffmpeg_where_missing(tmp_path, monkeypatch):
    """The command runs as printed in a shell whose PATH has no venv (rerun's --version stands in for the viewer,
    which needs a display); a path with a space is quoted; FFmpeg's role is said where it is not on PATH."""
    folder = tmp_path / "my take"
    entry = {"name": "take", "status": "ok", "outputs": [str(folder / "take.rrd")]}
    monkeypatch.setattr("shutil.which", lambda name: None)
    lines = written_lines([entry])
    assert lines[-1] == FFMPEG_NOTE and "FFmpeg" in lines[-1]
    command = lines[1].removeprefix("  look at it: ")
    assert shlex.split(command) == [sys.executable, "-m", "rerun", str(folder / "take.rrd")]
    done = subprocess.run(
        command.replace(shlex.quote(str(folder / "take.rrd")), "--version"),
        shell=True,
        env={"PATH": "/usr/bin:/bin", "HOME": str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0 and done.stdout.startswith("rerun-cli "), done.stderr[-300:]


def test_resume_does_not_say_it_wrote_the_files_of_inputs_it_skipped(tmp_path):
    folder = tmp_path / "take"
    skipped = {"name": "take", "status": "skipped", "outputs": [str(folder / "take.npz")]}
    assert written_lines([skipped]) == [f"take: kept, unchanged since an earlier run: take.npz in {folder}/"]
