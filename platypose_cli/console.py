"""What ``lift`` and ``demo`` print around a batch: lines that do not run into a progress bar, and at the end the
files written and the command that opens the recording."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

LISTED_INPUTS = 5  # a batch of more inputs names each one's folder only


def say_over_bar(message: str) -> None:
    """Print ``message`` on stderr on a line of its own: a progress bar drawn on a terminal's last line is cleared
    first (it is drawn again at its next update)."""
    prefix = "\r\033[K" if sys.stderr.isatty() else ""
    typer.echo(prefix + message, err=True)


def written_lines(entries: list[dict]) -> list[str]:
    """Per input lifted (or skipped by ``--resume``: its files kept, not written): its folder and the files in it,
    and ``rerun <recording>`` to look at it; with more than ``LISTED_INPUTS`` inputs, their folders only."""
    lifted = [e for e in entries if e["status"] in ("ok", "skipped") and e["outputs"]]
    lines = []
    for entry in lifted:
        paths = [Path(p) for p in entry["outputs"]]
        if len(lifted) > LISTED_INPUTS:
            lines.append(f"{entry['name']}: {len(paths)} files in {paths[0].parent}/")
            continue
        done = "wrote" if entry["status"] == "ok" else "kept, unchanged since an earlier run:"
        lines.append(f"{entry['name']}: {done} {', '.join(p.name for p in paths)} in {paths[0].parent}/")
        lines += [f"  look at it: rerun {p}" for p in paths if p.suffix == ".rrd"]
    return lines
