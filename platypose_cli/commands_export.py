"""``platypose info FILE.npz`` (summary of a result) and ``platypose export FILE.npz`` (re-export from it)."""

from __future__ import annotations

import json
from pathlib import Path

import typer


def _describe(path: Path, result) -> list[str]:
    """Summary lines of a LiftResult read from ``path``."""
    import numpy as np

    P, N, T = result.num_persons, result.num_hypotheses, result.num_frames
    lines = [
        f"{path.name}: {P} person(s) x {N} hypotheses x {T} frames at {result.fps:.3f} fps "
        f"({result.frame_times[0]:.3f}-{result.frame_times[-1]:.3f} s), 17 joints, metres, Z up"
    ]
    floor = (result.meta or {}).get("floor") or {}
    if floor.get("frame"):
        lines.append(f"  world: {floor['frame']}")
    where = " above the floor (z = 0)" if floor.get("normal") == [0.0, 0.0, 1.0] and not floor.get("offset_m") else ""
    present = result.present()
    for p, track in enumerate(result.track_ids):
        on = present[p]
        if not on.any():
            lines.append(f"  person {track}: absent in every frame")
            continue
        hyp, med = result.hypotheses[p][:, on], result.median[p][on]
        spread = np.sqrt(((hyp - med) ** 2).sum(-1).mean(0)) * 1000
        line = (
            f"  person {track}: present in {on.sum()}/{T} frames, pelvis height median {np.median(med[:, 0, 2]):.2f} m{where},"
            f" joint spread mean {spread.mean():.1f} mm (max {spread.max():.1f} mm)"
        )
        if result.energy is not None:
            line += f", energy median {np.median(result.energy[p][:, on]):.4g}"
        lines.append(line)
    for c, cam in enumerate(result.cameras):
        conf = result.keypoints2d[c, ..., 2]
        lines.append(
            f"  camera {cam.name}: {cam.width}x{cam.height} px, fx {cam.K[0, 0]:.1f}, "
            f"centre at ({', '.join(f'{v:.2f}' for v in cam.center)}) m, 2D keypoints with confidence > 0: "
            f"{(conf > 0).mean():.0%}"
        )
    meta = result.meta
    for key in ("version", "prior_sha256", "arguments", "timings", "bvh_fit_error"):
        if key in meta:
            lines.append(f"  {key}: {json.dumps(meta[key])}")
    others = sorted(set(meta) - {"version", "prior_sha256", "arguments", "timings", "bvh_fit_error"})
    if others:
        lines.append(f"  other meta: {', '.join(others)}")
    return lines


def _video_map(items: list[str], camera_names: list[str]) -> dict[str, Path]:
    """``NAME=PATH`` items (or one bare PATH when there is one camera) -> {camera name: path}."""
    from platypose.lifting.errors import InputError

    videos: dict[str, Path] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            if len(camera_names) != 1:
                raise InputError(f"--video {item}: give CAMERA=PATH (cameras: {', '.join(camera_names) or 'none'})")
            name, value = camera_names[0], item
        videos[name] = Path(value)
    return videos


def info(path: Path = typer.Argument(..., help="A platypose result file (OUT/<name>/<name>.npz).")) -> None:
    """Validate a result npz and print a summary: persons, hypotheses, frames, cameras, spread, meta."""
    from platypose.exporters.npz import read_npz

    result = read_npz(path)
    typer.echo("\n".join(_describe(path, result)))


def export_command(
    *,
    path: Path = typer.Argument(..., help="A platypose result file (.npz), the source of truth."),
    formats: str = typer.Option(
        "csv,bvh,rrd",
        "--formats",
        help="Comma-separated: npz, csv, csv-long (every hypothesis), bvh, trc, c3d, angles, mot (OpenSim IK), "
        "report, rrd (docs/outputs.md).",
    ),
    out: Path | None = typer.Option(None, "--out", help="Output folder (default: the npz's folder)."),
    name: str | None = typer.Option(
        None, "--name", help="Base name of the files (default: the npz's name), made a safe file name as lift's."
    ),
    bvh: str = typer.Option("median", "--bvh", help="median: one BVH per person; all: also one per hypothesis."),
    rrd_video: str = typer.Option(
        "asset", "--rrd-video", help="asset (MP4, re-encoded to H.264 if needed), frames (JPEG), none."
    ),
    video: list[str] = typer.Option([], "--video", help="CAMERA=VIDEO for the rerun recording; repeat per camera."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress lines."),
) -> None:
    """Re-export CSV, BVH and rerun files from a result npz (writing npz again only if asked)."""
    from platypose.cli.terminal.safe_names import printable, safe_name
    from platypose.exporters import export
    from platypose.exporters.npz import read_npz
    from platypose.lifting.files.atomic import check_writable

    base = safe_name(name or path.stem)  # one plain file name: the files stay inside --out
    if name is not None and base != name:
        typer.echo(printable(f"--name {name}: not a plain file name; the files are named {base}"), err=True)
    result = read_npz(path)
    videos = _video_map(video, [c.name for c in result.cameras])
    check_writable(out or path.parent, folder=True)

    def say(message: str) -> None:
        if not quiet:
            typer.echo(message, err=True)

    from platypose.cli.runs.workers import terminate_as_interrupt

    try:
        with terminate_as_interrupt():  # SIGTERM unwinds like Ctrl-C: no temporary file is left behind
            written = export(result, out or path.parent, base, formats, videos, bvh, rrd_video, say)
    except KeyboardInterrupt:
        import os
        import sys

        message = "interrupted; no file was left half-written (those finished before are new, the rest as they were)"
        typer.echo(message, err=True)
        sys.stdout.flush()
        sys.stderr.flush()
        # Every temporary file is gone by now; a native library stopped mid-task (OpenSim) can crash the
        # interpreter's teardown afterwards, so the process ends here.
        os._exit(130)
    for file in written:
        typer.echo(str(file))
