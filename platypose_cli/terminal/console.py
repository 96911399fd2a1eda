"""What the commands print: one line for an OSError; around a batch of ``lift`` and ``demo``, lines that do not run
into a progress bar, and at the end the files written and the command that opens the recording."""

from __future__ import annotations

import os
import shlex
import shutil
import sys
from pathlib import Path

import typer

LISTED_INPUTS = 5  # a batch of more inputs names each one's folder only


def describe_os_error(err: OSError) -> str:
    """One line for an OSError: the file(s) it names and the system's reason."""
    names = [str(n) for n in (err.filename, err.filename2) if n is not None]
    reason = err.strerror or str(err)
    return f"{' -> '.join(names)}: {reason}" if names else reason


def say_over_bar(message: str) -> None:
    """Print ``message`` on stderr on a line of its own: a progress bar drawn on a terminal's last line is cleared
    first (it is drawn again at its next update)."""
    prefix = "\r\033[K" if sys.stderr.isatty() else ""
    typer.echo(prefix + message, err=True)


def viewer_command(recording: Path) -> str:
    """The shell command that opens ``recording`` in the rerun viewer from any shell: this interpreter's absolute
    path with ``-m rerun`` (the ``rerun`` script is on PATH only in an activated venv) and the file's absolute path."""
    return shlex.join([sys.executable, "-m", "rerun", os.path.abspath(recording)])


FFMPEG_NOTE = (
    "  the viewer plays the videos with FFmpeg, not found on PATH here: install it (ffmpeg.org) to see them; "
    "the 3D and keypoints show without it"
)


def written_lines(entries: list[dict]) -> list[str]:
    """Per input lifted (or skipped by ``--resume``: its files kept, not written): its folder and the files in it,
    and the command that opens its recording (with a note where FFmpeg, which the viewer needs for the videos,
    is not on PATH); with more than ``LISTED_INPUTS`` inputs, their folders only."""
    lifted = [e for e in entries if e["status"] in ("ok", "skipped") and e["outputs"]]
    lines = []
    for entry in lifted:
        paths = [Path(p) for p in entry["outputs"]]
        if len(lifted) > LISTED_INPUTS:
            lines.append(f"{entry['name']}: {len(paths)} files in {paths[0].parent}/")
            continue
        done = "wrote" if entry["status"] == "ok" else "kept, unchanged since an earlier run:"
        lines.append(f"{entry['name']}: {done} {', '.join(p.name for p in paths)} in {paths[0].parent}/")
        lines += [f"  look at it: {viewer_command(p)}" for p in paths if p.suffix == ".rrd"]
    if any(line.startswith("  look at it: ") for line in lines) and shutil.which("ffmpeg") is None:
        lines.append(FFMPEG_NOTE)
    return lines
