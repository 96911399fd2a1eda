"""``platypose lift``: videos (or precomputed keypoints) -> multi-hypothesis 3D motion files, one folder per input."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from platypose.cli.terminal.brief_help import help_all_option
from platypose.cli.terminal.options import as_json, field_option, flags, settings_options
from platypose.lifting.settings import DetectOptions, TakeSettings

if TYPE_CHECKING:
    from platypose.lifting.settings import PriorSettings, SamplerConfig, WindowSettings

# what ``lift --help`` shows; ``--help-all`` shows every option (docs/lift.md's table lists them all)
LIFT_SHOWN = (
    "inputs",
    "cams",
    "keypoints",
    "out",
    "formats",
    "persons",
    "samples",
    "threads",
    "jobs",
    "resume",
    "quiet",
)
# the detection options a lift leaves to its own (--threads: torch's too) or to their defaults
LIFT_LEAVES = ("movenet_size", "threads", "provider", "max_frames", "cache")


def lift_arguments(values: dict) -> dict:
    """``meta["arguments"]`` of a lift: its options' values as JSON (the detection options one by one, an image size
    as HEIGHTxWIDTH), ``--help-all`` left out."""
    detect = values["detect"]
    taken = {f.field: getattr(detect, f.field) for f in flags("detect") if f.field not in LIFT_LEAVES}
    if taken["image_size"] is not None:
        taken["image_size"] = "x".join(map(str, taken["image_size"]))
    shown = {}
    for name, value in values.items():
        shown.update(taken if name == "detect" else {} if name == "help_all" else {name: value})
    return {k: as_json(v) for k, v in shown.items()}


def lift_settings(
    *,
    out: Path,
    cams: Path | None,
    prior: PriorSettings,
    detect: DetectOptions,
    sampler: SamplerConfig,
    windows: WindowSettings,
    formats: str,
    persons: str,
    root: str,
    root_file: Path | None,
    quiet: bool,
    arguments: dict,
    sync: str = "none",
    floor: str = "auto",
):
    """Checked RunSettings from CLI values (InputError for bad ones, before any work starts)."""
    from platypose.cli.runs.job import RunSettings
    from platypose.exporters.export import parse_formats
    from platypose.lifting.files.atomic import check_writable
    from platypose.lifting.prior.runtime import resolve_device
    from platypose.lifting.settings import TakeSettings

    take = TakeSettings(
        persons=persons, root=root, root_trajectory=root_file, floor=floor, sync=sync, sampler=sampler, windows=windows
    )
    resolve_device(prior.device)
    check_writable(out, folder=True)
    chosen = parse_formats((*parse_formats(formats), "npz"))  # the npz, the source of truth, always
    if "mot" in chosen:
        from platypose.exporters.mot import load_opensim

        load_opensim()  # InputError without the opensim package: before anything is detected, not per input
    return RunSettings(
        out=out,
        cams=cams,
        prior=prior,
        detect=detect,
        take=take,
        formats=chosen,
        quiet=quiet,
        arguments=arguments,
    )


def ray_executor(executor: str, address: str | None, cpus_per_input: int, collect: bool, jobs: int):
    """The RayExecutor for ``--executor ray`` (Ray importable), None for local; InputError for misplaced options."""
    from platypose.lifting.errors import InputError

    if executor not in ("local", "ray"):
        raise InputError(f"--executor must be local or ray, got {executor!r}")
    if executor == "local":
        given = [name for name, on in (("--ray-address", address), ("--collect", collect)) if on]
        given += ["--cpus-per-input"] if cpus_per_input != 1 else []
        if given:
            raise InputError(f"{', '.join(given)}: only with --executor ray")
        return None
    if jobs != 1:
        raise InputError("--jobs is for --executor local; with ray, --cpus-per-input sets how many inputs share a node")
    from platypose.cli.runs.ray import RayExecutor, RayOptions, import_ray

    import_ray()
    return RayExecutor(RayOptions(address=address, cpus_per_input=cpus_per_input, collect=collect))


def finish(entries: list[dict], out: Path) -> None:
    """Print the batch's outcome and its warnings; exit 2 if inputs failed for bad input only, 1 if any other way."""
    from platypose.cli.terminal.safe_names import printable

    failed = [e for e in entries if e["status"] == "failed"]
    counts = ", ".join(f"{sum(e['status'] == s for e in entries)} {s}" for s in ("ok", "failed", "skipped"))
    from platypose.cli.terminal.console import written_lines

    for line in written_lines(entries):
        typer.echo(line)
    typer.echo(f"{len(entries)} input(s): {counts}; summary in {out / 'summary.json'}")
    for entry in entries:
        for warning in entry.get("warnings", []):
            typer.echo(printable(f"warning: {entry['name']}: {warning}"), err=True)
    for entry in failed:
        typer.echo(printable(f"  failed {entry['input']}: {entry['error']}"), err=True)
    if failed:
        raise typer.Exit(2 if all(e.get("error_kind") == "input" for e in failed) else 1)


def _own_folders(jobs: list, out: Path) -> list:
    """``jobs`` renamed where ``out`` holds another input's folder of their name (a line says so, even with -q)."""
    from platypose.cli.runs.folders import claim_folders
    from platypose.cli.terminal.safe_names import printable

    placed = claim_folders(jobs, out)
    for job, moved in zip(jobs, placed):
        if moved.name != job.name:
            say = f"{job.input}: {out / job.name}/ holds another input's results; writing {out / moved.name}/"
            typer.echo(printable(say), err=True)
    return placed


@settings_options("prior")
@settings_options("sampler")
@settings_options("windows")
@settings_options("detect", exclude=LIFT_LEAVES, panel="Input", short=True, in_place=True)
def lift(
    *,
    inputs: list[str] = typer.Argument(
        None,
        help="Videos, several views of one take (matched to --cams by name), folders (each video or sub-folder of "
        "views is one input) or globs. Optional with --keypoints.",
    ),
    cams: Path | None = typer.Option(
        None, "--cams", help="Calibration (native JSON, Pose2Sim/anipose TOML, ...).", rich_help_panel="Input"
    ),
    keypoints: Path | None = typer.Option(
        None,
        "--keypoints",
        help="Precomputed 2D instead of detection: a file or OpenPose folder for one view, or a folder of per-view "
        "sub-folders/files named after the cameras (cam01_json for cam_01).",
        rich_help_panel="Input",
    ),
    detect: DetectOptions = None,
    out: Path = typer.Option(
        Path("out"), "--out", help="Output folder: OUT/<name>/ per input, OUT/summary.json.", rich_help_panel="Output"
    ),
    formats: str = typer.Option(
        "npz,csv,bvh,rrd",
        "--formats",
        help="Comma-separated: npz, csv, csv-long (every hypothesis), bvh, trc, c3d, angles, mot (OpenSim IK), "
        "report, rrd (docs/outputs.md). The npz is always written: export makes the others from it.",
        rich_help_panel="Output",
    ),
    persons: str = field_option(TakeSettings, "persons", "People"),
    root: str = field_option(TakeSettings, "root", "People"),
    root_trajectory: Path | None = field_option(TakeSettings, "root_trajectory", "People"),
    sync: str = field_option(TakeSettings, "sync", "Input"),
    jobs: int = typer.Option(1, "--jobs", min=1, help="Inputs lifted in parallel processes.", rich_help_panel="Run"),
    split_seconds: float | None = typer.Option(
        None,
        "--split-seconds",
        help="Spread each input over pieces of this many seconds, run in parallel (with --jobs N or --executor ray; "
        "docs/ray.md).",
        rich_help_panel="Run",
    ),
    executor: str = typer.Option(
        "local",
        "--executor",
        help="local (this machine, --jobs processes) or ray (one Ray task per input).",
        rich_help_panel="Ray",
    ),
    ray_address: str | None = typer.Option(
        None,
        "--ray-address",
        help="Ray: auto (the cluster of this node) or ray://HOST:10001 (default: a Ray on this machine).",
        rich_help_panel="Ray",
    ),
    cpus_per_input: int = typer.Option(
        1, "--cpus-per-input", min=1, help="Ray: CPUs (and threads) of each task.", rich_help_panel="Ray"
    ),
    collect: bool = typer.Option(
        False,
        "--collect",
        help="Ray: workers send outputs to this machine, which writes --out (default: they write it).",
        rich_help_panel="Ray",
    ),
    threads: int | None = typer.Option(
        None,
        "--threads",
        min=1,
        help="torch and onnxruntime threads per input (default: 1, measured fastest on a busy machine).",
        rich_help_panel="Run",
    ),
    resume: bool = typer.Option(
        False,
        "--resume",
        help="Skip inputs whose outputs are complete, and unchanged inputs that failed.",
        rich_help_panel="Output",
    ),
    retry_failed: bool = typer.Option(
        False, "--retry-failed", help="With --resume: run failed inputs again.", rich_help_panel="Output"
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars.", rich_help_panel="Output"),
    floor: str = field_option(TakeSettings, "floor", "People"),
    help_all: bool = help_all_option(),
    prior: PriorSettings = None,
    sampler: SamplerConfig = None,
    windows: WindowSettings = None,
) -> None:
    """Lift people in videos to calibrated 3D motion hypotheses (docs/lift.md)."""
    arguments = lift_arguments(locals())
    from platypose.cli.runs.batch import run_batch
    from platypose.cli.runs.jobs import (
        check_camera_count,
        check_views_match,
        discover_jobs,
        expand_inputs,
        keypoints_job,
    )
    from platypose.cli.terminal.console import say_over_bar
    from platypose.cli.terminal.safe_names import printable
    from platypose.lifting.errors import InputError
    from platypose.lifting.files.reads import check_readable_inputs

    if keypoints is not None and detect.detector is not None:
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
    if cams is not None:
        check_views_match(job_list, camera_names, cams)
        if keypoints is None:
            check_camera_count(job_list, camera_names, cams)
    given = [v.source for job in job_list for v in job.views] + [
        p for p in (root_trajectory, prior.path if prior else None) if p
    ]
    check_readable_inputs(given)
    job_list = _own_folders(job_list, out)
    detect = replace(detect, threads=threads)
    settings = lift_settings(
        out=out,
        cams=cams,
        prior=prior,
        detect=detect,
        sampler=sampler,
        windows=windows,
        formats=formats,
        persons=persons,
        root=root,
        root_file=root_trajectory,
        quiet=quiet,
        arguments=arguments,
        sync=sync,
        floor=floor,
    )
    if root_trajectory is not None and len(job_list) > 1:
        raise InputError(f"--root-trajectory {root_trajectory}: give it for one input, not {len(job_list)}")

    batch_executor = ray_executor(executor, ray_address, cpus_per_input, collect, jobs)
    if split_seconds is not None:  # one input's pieces in parallel (docs/ray.md)
        from platypose.cli.runs.split import split_executor

        options = None if batch_executor is None else batch_executor.options
        batch_executor = split_executor(split_seconds, windows.max_gap, jobs, options, collect)
        settings = replace(settings, split_seconds=split_seconds)

    if quiet:  # -q: numpy's RuntimeWarnings (all-NaN slices of absent persons) are not the user's to read
        import warnings

        warnings.simplefilter("ignore", RuntimeWarning)

    def say(message: str) -> None:
        if not quiet:
            say_over_bar(printable(message))

    try:
        entries = run_batch(
            job_list, settings, workers=jobs, resume=resume, say=say, retry_failed=retry_failed, executor=batch_executor
        )
    except KeyboardInterrupt:
        done = (out / "summary.json").is_file()
        typer.echo(
            f"interrupted; {out / 'summary.json'} lists the inputs that finished"
            if done
            else "interrupted; no input finished",
            err=True,
        )
        raise typer.Exit(130) from None
    finish(entries, out)
