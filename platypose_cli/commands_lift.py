"""``platypose lift``: videos (or precomputed keypoints) -> multi-hypothesis 3D motion files, one folder per input."""

from __future__ import annotations

from pathlib import Path

import typer

from platypose.cli.app import app
from platypose.cli.detection import DetectOptions


def lift_settings(
    out: Path,
    cams: Path | None,
    prior: Path | None,
    detect: DetectOptions,
    sampler: dict,
    window: int,
    overlap: int,
    formats: str,
    persons: str,
    root: str,
    root_file: Path | None,
    quiet: bool,
    arguments: dict,
    device: str = "cpu",
):
    """Checked RunSettings from CLI values (InputError for bad ones, before any work starts)."""
    from platypose.cli.lift_run import ROOT_MODES, RunSettings
    from platypose.cli.options import sampler_config
    from platypose.detectors.tracking import persons_count
    from platypose.exporters.export import parse_formats
    from platypose.lifting.errors import InputError
    from platypose.lifting.runtime import resolve_device

    persons_count(persons)
    sampler_config(**sampler)
    resolve_device(device)
    if root not in ROOT_MODES:
        raise InputError(f"--root must be one of {', '.join(ROOT_MODES)}, got {root!r}")
    if window < 2 or not 0 <= overlap <= window // 2:
        raise InputError(f"--window must be >= 2 and --overlap in 0..window/2, got {window} and {overlap}")
    return RunSettings(
        out=out,
        cams=cams,
        prior=prior,
        detect=detect,
        sampler=sampler,
        window=window,
        overlap=overlap,
        formats=parse_formats(formats),
        persons=persons,
        root=root,
        root_file=root_file,
        quiet=quiet,
        arguments=arguments,
        device=device,
    )


def finish(entries: list[dict], out: Path) -> None:
    """Print the batch's outcome and exit 1 if any input failed."""
    failed = [e for e in entries if e["status"] == "failed"]
    counts = ", ".join(f"{sum(e['status'] == s for e in entries)} {s}" for s in ("ok", "failed", "skipped"))
    typer.echo(f"{len(entries)} input(s): {counts}; summary in {out / 'summary.json'}")
    for entry in failed:
        typer.echo(f"  failed {entry['input']}: {entry['error']}", err=True)
    if failed:
        raise typer.Exit(1)


@app.command("lift")
def lift(
    inputs: list[str] = typer.Argument(
        None,
        help="Videos, several views of one take (matched to --cams by name), folders (each video or sub-folder of "
        "views is one input) or globs. Optional with --keypoints.",
    ),
    cams: Path | None = typer.Option(None, "--cams", help="Calibration (native JSON, Pose2Sim/anipose TOML, ...)."),
    keypoints: Path | None = typer.Option(
        None,
        "--keypoints",
        help="Precomputed 2D instead of detection: a file or OpenPose folder for one view, or a folder of per-view "
        "sub-folders/files named after the cameras (cam01_json for cam_01).",
    ),
    detector: Path | None = typer.Option(None, "--detector", help="Pose model .onnx (default: bundled MoveNet)."),
    detector_format: str | None = typer.Option(None, "--detector-format", help="Model contract (default: recognised)."),
    person_detector: Path | None = typer.Option(None, "--person-detector", help="Person detector for top-down models."),
    prior: Path | None = typer.Option(None, "--prior", help="Motion prior checkpoint (default: the shipped one)."),
    out: Path = typer.Option(Path("out"), "--out", help="Output folder: OUT/<name>/ per input, OUT/summary.json."),
    samples: int | None = typer.Option(None, "--samples", help="Hypotheses per person [sampler default: 50]."),
    steps: int | None = typer.Option(None, "--steps", help="Diffusion steps kept, of 50 [10]."),
    skip: int | None = typer.Option(None, "--skip", help="Noisiest kept steps skipped [2]."),
    guidance_iters: int | None = typer.Option(None, "--guidance-iters", help="Guidance steps per diffusion step [10]."),
    eta: float | None = typer.Option(None, "--eta", help="DDIM eta: 0 deterministic re-noising, 1 fresh noise [0]."),
    robust: str | None = typer.Option(None, "--robust", help="Reprojection loss: l2 or geman-mcclure [l2]."),
    bone_weight: float | None = typer.Option(None, "--bone-weight", help="Constant bone lengths over time [0: off]."),
    symmetry_weight: float | None = typer.Option(None, "--symmetry-weight", help="Left/right bone symmetry [0: off]."),
    depth_smoothness: float | None = typer.Option(
        None, "--depth-smoothness", help="One view: smoothness of every joint's depth path [10; 0: off]."
    ),
    noise_fit: bool | None = typer.Option(
        None, "--noise-fit/--no-noise-fit", help="Follow the 2D only as far as its measured jitter allows [on]."
    ),
    noise_spread: bool | None = typer.Option(
        None, "--noise-spread/--no-noise-spread", help="2+ views: spread hypotheses by the 2D noise [on]."
    ),
    window: int = typer.Option(64, "--window", help="Window length in prior frames (capped by the prior)."),
    overlap: int = typer.Option(16, "--overlap", help="Frames shared by consecutive windows."),
    formats: str = typer.Option("npz,csv,bvh,rrd", "--formats", help="Comma-separated: npz, csv, bvh, rrd."),
    persons: str = typer.Option("all", "--persons", help="Who to lift: all, largest, or N (the N largest)."),
    root: str = typer.Option(
        "auto", "--root", help="Root path: auto (triangulated with 2+ views, else solved), triangulate, solve."
    ),
    root_trajectory: Path | None = typer.Option(
        None, "--root-trajectory", help="Known pelvis path: npz (frame_times, root) or CSV (time,x,y,z)."
    ),
    fps: float | None = typer.Option(None, "--fps", help="Frame rate of keypoints without a video beside them."),
    image_size: str | None = typer.Option(None, "--image-size", help="HEIGHTxWIDTH of keypoints without a video."),
    stride: int = typer.Option(1, "--stride", min=1, help="Detect every N-th frame."),
    jobs: int = typer.Option(1, "--jobs", min=1, help="Inputs lifted in parallel processes."),
    threads: int | None = typer.Option(
        None, "--threads", min=1, help="torch and onnxruntime threads per input (default: cores / jobs)."
    ),
    resume: bool = typer.Option(
        False, "--resume", help="Skip inputs whose outputs are complete, and unchanged inputs that failed."
    ),
    retry_failed: bool = typer.Option(False, "--retry-failed", help="With --resume: run failed inputs again."),
    seed: int | None = typer.Option(None, "--seed", help="Random seed of the sampler [0]."),
    device: str = typer.Option("cpu", "--device", help="Sampler device: cpu, cuda or auto (cuda when available)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars."),
) -> None:
    """Lift people in videos to calibrated 3D motion hypotheses (docs/lift.md)."""
    arguments = {k: (str(v) if isinstance(v, Path) else v) for k, v in locals().items()}
    from platypose.cli.lift_batch import run_batch
    from platypose.cli.lift_jobs import discover_jobs, expand_inputs, keypoints_job
    from platypose.lifting.errors import InputError

    if keypoints is not None and detector is not None:
        raise InputError("--keypoints and --detector exclude each other: keypoints are read, not detected")
    if not inputs and keypoints is None:
        raise InputError("give INPUT videos or folders, or --keypoints")
    camera_names: tuple[str, ...] = ()
    if cams is not None:
        from platypose.lifting.calibration import load_calibration

        camera_names = load_calibration(cams).names
    paths = expand_inputs(inputs or [])
    if keypoints is not None:
        job_list = [keypoints_job(keypoints, paths, camera_names)]
    else:
        job_list = discover_jobs(paths, camera_names)
    given = {
        "samples": samples,
        "steps": steps,
        "skip": skip,
        "eta": eta,
        "guidance_iters": guidance_iters,
        "robust": robust,
        "bone_weight": bone_weight,
        "symmetry_weight": symmetry_weight,
        "depth_smoothness": depth_smoothness,
        "noise_fit": noise_fit,
        "noise_spread": noise_spread,
        "seed": seed,
    }
    sampler = {k: v for k, v in given.items() if v is not None}  # the rest: SamplerConfig's defaults
    detect = DetectOptions(
        detector, detector_format, person_detector, threads=threads, stride=stride, fps=fps, image_size=image_size
    )
    settings = lift_settings(
        out,
        cams,
        prior,
        detect,
        sampler,
        window,
        overlap,
        formats,
        persons,
        root,
        root_trajectory,
        quiet,
        arguments,
        device,
    )
    if root_trajectory is not None and len(job_list) > 1:
        raise InputError(f"--root-trajectory {root_trajectory}: give it for one input, not {len(job_list)}")

    def say(message: str) -> None:
        if not quiet:
            typer.echo(message, err=True)

    try:
        entries = run_batch(job_list, settings, jobs, resume, say, retry_failed)
    except KeyboardInterrupt:
        typer.echo(f"interrupted; {out / 'summary.json'} lists the inputs that finished", err=True)
        raise typer.Exit(130) from None
    finish(entries, out)
