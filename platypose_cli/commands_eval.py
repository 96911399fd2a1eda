"""``platypose eval``: lift known 3D motion projected through cameras and print the paper's metrics."""

from __future__ import annotations

import json
import os
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from platypose.cli.app import app
from platypose.cli.options import int_list, settings_options
from platypose.lifting.atomic import write_text_atomic
from platypose.lifting.errors import InputError

if TYPE_CHECKING:
    from platypose.lifting.settings import PriorSettings, SamplerConfig


def floor_plane(text: str) -> tuple[float, float, float, float] | None:
    """The level floor ``--floor`` gives evaluation: auto is the motion's z = 0; InputError for a tilted plane."""
    from platypose.lifting.floor import CALIBRATED_FLOOR, parse_floor
    from platypose.lifting.offline.evaluation import floor_height

    floor = parse_floor(text)
    plane = CALIBRATED_FLOOR.plane if floor == "auto" else (None if floor is None else floor.plane)
    try:
        floor_height(plane)
    except ValueError as err:
        raise InputError(f"--{err}") from None
    return plane


@app.command("eval")
@settings_options("prior")
@settings_options("sampler", exclude=("samples",))  # --samples: a list, one table row each
def evaluate_command(
    motion: list[Path] = typer.Argument(..., help="3D motion files or folders to project and lift."),
    cams: Path = typer.Option(None, "--cams", help="Calibration file; default: a ring of 4 Human3.6M-like cameras."),
    views: int = typer.Option(None, help="Use only the first this many cameras (at least 1; default: all)."),
    frames: str = typer.Option("1,16,64", help="Window lengths to evaluate, comma-separated."),
    samples: str = typer.Option("50,200", help="Numbers of hypotheses, comma-separated."),
    noise_px: float = typer.Option(0.0, help="Gaussian noise (px, std) added to the projected 2D keypoints."),
    windows: int = typer.Option(2, help="Windows cut from each clip per window length."),
    heldout: bool = typer.Option(False, "--heldout", help="Only clips the prior held out of training (its manifest)."),
    baseline: bool = typer.Option(True, help="Also run the frame-by-frame baseline."),
    rigid: bool = typer.Option(True, help="Make hypotheses rigid as platypose lift does (--no-rigid: as sampled)."),
    gap: float = typer.Option(
        0.0,
        help="Also lift every window with a centred gap of this many seconds no camera sees, and score the frames "
        "inside and outside the gap apart (0: no gap rows).",
    ),
    json_out: Path = typer.Option(None, "--json", help="Also write the table as JSON here."),
    floor: str = typer.Option(
        "auto",
        "--floor",
        help="auto (the motion's floor z = 0, known to the sampler), z=H (the motion stood on that floor), or none "
        "(motion placed by its pelvis, no floor).",
    ),
    prior: PriorSettings = None,
    sampler: SamplerConfig = None,
) -> None:
    """Project motion through cameras, lift it, and print minMPJPE, minMPSPE, PA-*, MPJVE, ECE."""
    import math

    from platypose.lifting.atomic import check_writable
    from platypose.lifting.camera_rigs import ring_cameras
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.evaluation import evaluate, floor_height, format_header
    from platypose.lifting.timebase import resample

    if views is not None and views < 1:
        raise InputError(f"--views {views}: use at least 1 camera (leave it out for all)")
    if windows < 1:
        raise InputError(f"--windows {windows}: cut at least 1 window from each clip")
    if not (math.isfinite(noise_px) and noise_px >= 0):
        raise InputError(f"--noise-px {noise_px}: must be a finite number of pixels, 0 or more")
    if not (math.isfinite(gap) and gap >= 0):
        raise InputError(f"--gap {gap}: must be a finite number of seconds, 0 or more")
    if json_out is not None:
        check_writable(json_out)  # before the evaluation, not after it
    frames_list = int_list(frames, "--frames")
    samples_list = int_list(samples, "--samples")
    plane = floor_plane(floor)
    config = replace(sampler, floor=plane)
    bundle = prior.load()
    if max(frames_list) > bundle.config.max_frames:
        raise InputError(f"--frames: the prior handles at most {bundle.config.max_frames} frames")
    if cams is not None:
        from platypose.lifting.calibration import load_calibration

        cameras = list(load_calibration(cams).cameras)
    else:
        cameras = ring_cameras(4)
    if views is not None:
        if views > len(cameras):
            raise InputError(f"--views {views}: only {len(cameras)} cameras")
        cameras = cameras[:views]
    motions = load_motion_paths(motion)
    if heldout:
        names = {c["name"] for c in bundle.manifest.get("clips", []) if c.get("split") == "validation"}
        motions = [m for m in motions if m.name in names]
    clips = [resample(m.joints, m.fps, bundle.fps) for m in motions]
    clips = [c for c in clips if len(c) and not (c != c).any()]
    if not clips:
        raise InputError(f"{', '.join(map(str, motion))}: no complete (full-body) clips to evaluate")
    longest = max(len(c) for c in clips)
    too_long = [f for f in frames_list if f > longest]
    if too_long:  # no window of that length: its rows would be missing from the table
        raise InputError(
            f"--frames {','.join(map(str, too_long))}: longer than every clip (the longest has {longest} frames at "
            f"the prior's {bundle.fps:g} fps)"
        )
    typer.echo(
        f"{len(clips)} clips, prior {bundle.checksum[:12]}, {len(cameras)} cameras, noise {noise_px} px, "
        f"floor {'none' if plane is None else f'z = {floor_height(plane):g}'}, {os.cpu_count()} CPUs"
    )
    typer.echo(format_header())
    rows = evaluate(
        bundle,
        clips,
        cameras,
        frames_list,
        samples_list,
        config,
        windows,
        noise_px,
        baseline,
        progress=typer.echo,
        rigid=rigid,
        gap_s=gap,
    )
    if json_out:
        payload = {
            "prior": bundle.checksum,
            "cameras": len(cameras),
            "noise_px": noise_px,
            "rigid": rigid,
            "gap_s": gap,
            "config": config.__dict__,
            "rows": [r.as_dict() for r in rows],
        }
        write_text_atomic(json_out, json.dumps(payload, indent=2))
