"""``platypose eval``: lift known 3D motion projected through cameras and print the paper's metrics."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from platypose.cli.terminal.options import int_list, settings_options
from platypose.lifting.errors import InputError

if TYPE_CHECKING:
    from platypose.lifting.settings import PriorSettings, SamplerConfig

MAX_GAP_S = 24 * 3600.0  # --gap above a day is no gap in a window (as offsets are bounded)


@settings_options("prior")
@settings_options("sampler", exclude=("samples",))  # --samples: a list, one table row each
def evaluate_command(
    *,
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
    from platypose.lifting.offline.eval_run import EvalRun, floor_plane, run_evaluation

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
    run = EvalRun(
        motion=tuple(motion or ()),
        sets=sets,
        cams=cams,
        views=views,
        frames=tuple(int_list(frames, "--frames")),
        samples=tuple(int_list(samples, "--samples")),
        noise_px=noise_px,
        windows=windows,
        heldout=heldout,
        baseline=baseline,
        rigid=rigid,
        gap_s=gap,
        json_out=json_out,
    )
    run_evaluation(run, prior, replace(sampler, floor=floor_plane(floor)), say=typer.echo)


def calibrate_prior(
    *,
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

    from platypose.lifting.offline.eval_run import calibrate_temperatures

    frames_list = int_list(frames, "--frames")
    try:
        temperatures = sorted({float(v) for v in grid.split(",") if v.strip()})
    except ValueError:
        raise InputError(f"--grid: expected comma-separated numbers, got {grid!r}") from None
    if not temperatures or not all(0.05 <= t <= 2 for t in temperatures):
        raise InputError(f"--grid: temperatures must lie in [0.05, 2], got {grid!r}")
    if windows < 1 or samples < 2:
        raise InputError("--windows must be at least 1 and --samples at least 2")
    calibrate_temperatures(
        data,
        prior_path,
        out,
        frames=frames_list,
        windows=windows,
        samples=samples,
        temperatures=temperatures,
        seed=seed,
        threads=threads,
        say=typer.echo,
    )
