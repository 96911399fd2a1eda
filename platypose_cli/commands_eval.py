"""``platypose eval``: lift known 3D motion projected through cameras and print the paper's metrics."""

from __future__ import annotations

import json
import os
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from platypose.cli.terminal.options import int_list, settings_options
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import write_text_atomic

if TYPE_CHECKING:
    from platypose.lifting.settings import PriorSettings, SamplerConfig

MAX_GAP_S = 24 * 3600.0  # --gap above a day is no gap in a window (as offsets are bounded)


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


@settings_options("prior")
@settings_options("sampler", exclude=("samples",))  # --samples: a list, one table row each
def evaluate_command(
    motion: list[Path] = typer.Argument(None, help="3D motion files or folders to project and lift."),
    sets: Path = typer.Option(
        None,
        "--sets",
        help="JSON file of unseen sets (data/motion/unseen.json): evaluate each set on its own, a table each "
        "(instead of MOTION).",
    ),
    cams: Path = typer.Option(None, "--cams", help="Calibration file; default: a ring of 4 Human3.6M-like cameras."),
    views: int = typer.Option(None, help="Use only the first this many cameras (at least 1; default: all)."),
    frames: str = typer.Option("1,16,64", help="Window lengths to evaluate, comma-separated."),
    samples: str = typer.Option("50,200", help="Numbers of hypotheses, comma-separated."),
    noise_px: float = typer.Option(0.0, help="Gaussian noise (px, std) added to the projected 2D keypoints."),
    windows: int = typer.Option(2, help="Windows cut from each clip per window length."),
    heldout: bool = typer.Option(
        False,
        "--heldout",
        help="Only clips the prior held out of training (its manifest), less those its temperature was fitted on.",
    ),
    baseline: bool = typer.Option(True, help="Also run the frame-by-frame baseline."),
    rigid: bool = typer.Option(True, help="Make hypotheses rigid as platypose lift does (--no-rigid: as sampled)."),
    gap: float = typer.Option(
        0.0,
        help="Also lift every window with a centred gap of this many seconds no camera sees, and score the frames "
        "inside and outside the gap apart (0: no gap rows; at most a day). A gap longer than a window hides all but its "
        "first and last frame; the rows are labelled with the seconds hidden.",
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

    from platypose.lifting.files.atomic import check_writable
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.camera_rigs import ring_cameras
    from platypose.lifting.offline.evaluation import evaluate, floor_height, format_header
    from platypose.lifting.timebase import resample

    if views is not None and views < 1:
        raise InputError(f"--views {views}: use at least 1 camera (leave it out for all)")
    if windows < 1:
        raise InputError(f"--windows {windows}: cut at least 1 window from each clip")
    if not (math.isfinite(noise_px) and noise_px >= 0):
        raise InputError(f"--noise-px {noise_px}: must be a finite number of pixels, 0 or more")
    if not 0 <= gap <= MAX_GAP_S:  # NaN fails too
        raise InputError(f"--gap {gap:g}: give a number of seconds from 0 to {MAX_GAP_S:g} (a day)")
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
    if bool(motion) == (sets is not None):
        raise InputError("eval: give MOTION (files or folders) or --sets (a file of unseen sets), not both")
    if sets is not None:
        from platypose.lifting.offline.unseen_sets import load_sets

        named = load_sets(sets)
    else:
        named = {"": list(motion)}
    payload_sets = {}
    for name, paths in named.items():
        motions = load_motion_paths(paths)
        if heldout:
            from platypose.lifting.offline.calibration import calibration_clip_names

            names = {c["name"] for c in bundle.manifest.get("clips", []) if c.get("split") == "validation"}
            names -= set(calibration_clip_names(bundle.manifest)) if "temperature" in bundle.manifest else set()
            motions = [m for m in motions if m.name in names]
        clips = [resample(m.joints, m.fps, bundle.fps) for m in motions]
        clips = [c for c in clips if len(c) and not (c != c).any()]
        if not clips:
            where = f"set '{name}' of {sets}" if name else ", ".join(map(str, motion))
            raise InputError(f"{where}: no complete (full-body) clips to evaluate")
        longest = max(len(c) for c in clips)
        too_long = [f for f in frames_list if f > longest]
        if too_long:  # no window of that length: its rows would be missing from the table
            raise InputError(
                f"--frames {','.join(map(str, too_long))}: longer than every clip (the longest has {longest} frames "
                f"at the prior's {bundle.fps:g} fps)"
            )
        typer.echo(
            (f"set {name}: " if name else "")
            + f"{len(clips)} clips, prior {bundle.checksum[:12]}, {len(cameras)} cameras, noise {noise_px} px, "
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
        payload_sets[name] = [r.as_dict() for r in rows]
    if json_out:
        payload = {
            "prior": bundle.checksum,
            "cameras": len(cameras),
            "noise_px": noise_px,
            "rigid": rigid,
            "gap_s": gap,
            "config": config.__dict__,
            **({"sets": payload_sets} if sets is not None else {"rows": payload_sets[""]}),
        }
        write_text_atomic(json_out, json.dumps(payload, indent=2))


def calibrate_prior(
    data: list[Path] = typer.Argument(..., help="Motion files or folders holding the prior's validation clips."),
    prior_path: Path = typer.Option(None, "--prior", help="Prior to calibrate (default: the shipped one)."),
    out: Path = typer.Option(..., "--out", help="Calibrated checkpoint to write (may be --prior itself)."),
    frames: str = typer.Option("1,16,64", help="Window lengths to fit a temperature for, comma-separated."),
    windows: int = typer.Option(8, help="Windows cut from each calibration clip per window length."),
    samples: int = typer.Option(50, help="Hypotheses per window."),
    grid: str = typer.Option(
        "0.7,0.8,0.9,1,1.1,1.25,1.4", help="Temperatures tried per window length, comma-separated."
    ),
    seed: int = typer.Option(0, help="Sampler seed."),
    threads: int = typer.Option(1, help="Torch threads."),
) -> None:
    """Fit the prior's one-view temperature per window length on half its validation clips (never evaluated by
    eval --heldout) and write it into the checkpoint's manifest, which the sampler then applies."""
    from platypose.lifting.files.atomic import check_writable
    from platypose.lifting.floor import CALIBRATED_FLOOR
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.calibration import calibration_clip_names, fit_temperatures
    from platypose.lifting.offline.camera_rigs import ring_cameras
    from platypose.lifting.prior.model import load_prior, save_prior
    from platypose.lifting.prior.runtime import load_for_runtime
    from platypose.lifting.settings import SamplerConfig
    from platypose.lifting.timebase import resample

    frames_list = int_list(frames, "--frames")
    try:
        temperatures = sorted({float(v) for v in grid.split(",") if v.strip()})
    except ValueError:
        raise InputError(f"--grid: expected comma-separated numbers, got {grid!r}") from None
    if not temperatures or not all(0.05 <= t <= 2 for t in temperatures):
        raise InputError(f"--grid: temperatures must lie in [0.05, 2], got {grid!r}")
    if windows < 1 or samples < 2:
        raise InputError("--windows must be at least 1 and --samples at least 2")
    check_writable(out)
    bundle, extra = load_prior(prior_path)
    if max(frames_list) > bundle.config.max_frames:
        raise InputError(f"--frames: the prior handles at most {bundle.config.max_frames} frames")
    names = set(calibration_clip_names(bundle.manifest))
    motions = [m for m in load_motion_paths(data) if m.name in names]
    clips = [resample(m.joints, m.fps, bundle.fps) for m in motions]
    clips = [c for c in clips if len(c) and not (c != c).any()]
    if not clips:
        raise InputError(f"{', '.join(map(str, data))}: none of the prior's calibration clips is here")
    typer.echo(f"fitting on {len(clips)} of the prior's validation clips: {', '.join(m.name for m in motions)}")
    sampler = SamplerConfig(samples=samples, seed=seed, floor=CALIBRATED_FLOOR.plane)
    fitted = fit_temperatures(
        load_for_runtime(prior_path, "cpu", "auto", threads),
        clips,
        ring_cameras(4)[0],
        frames_list,
        sampler,
        windows,
        temperatures,
        progress=typer.echo,
    )
    fitted.update({"views": 1, "clips": sorted(names), "samples": samples, "windows": windows, "seed": seed})
    bundle.manifest["temperature"] = fitted
    checksum = save_prior(out, bundle, extra=extra or None)
    chosen = ", ".join(f"{f} frames {t:g}" for f, t in fitted["by_frames"].items())
    typer.echo(f"wrote {out} (sha256 {checksum[:12]}): temperature {chosen}")
