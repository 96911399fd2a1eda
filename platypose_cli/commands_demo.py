"""``platypose demo``: lift the bundled Pose2Sim take (a real lab clip with its calibration) end to end."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from platypose.cli.terminal.options import as_json, settings_options

if TYPE_CHECKING:
    from platypose.lifting.settings import PriorSettings, SamplerConfig

SOURCES = ("videos", "keypoints")


def demo_take() -> Path:
    """The bundled take, installed with the package (``platypose.data``)."""
    from platypose.data import VIDEO_DIR

    return VIDEO_DIR / "pose2sim-balancing"


def demo_job(take: Path, source: str):
    """The demo's job: cam01 + cam02 videos (bundled detector) or the OpenPose keypoints of all 4 views."""
    from platypose.cli.runs.jobs import discover_jobs, keypoints_job
    from platypose.lifting.calibration import load_calibration
    from platypose.lifting.errors import InputError

    if not (take / "calib_pose2sim.toml").is_file():
        raise InputError(f"{take}: the demo take is not there; reinstall platypose (it ships as package data)")
    names = load_calibration(take / "calib_pose2sim.toml").names
    if source == "keypoints":
        return keypoints_job(take / "openpose-body25b", [], names)
    if source != "videos":
        raise InputError(f"--source must be one of {', '.join(SOURCES)}, got {source!r}")
    return discover_jobs([take / "cam01.mp4", take / "cam02.mp4"], names)[0]


def describe(npz: Path) -> list[str]:
    """A few lines about a lift result: size, and per person presence, pelvis height and hypothesis spread."""
    import numpy as np

    from platypose.exporters.npz import read_npz

    result = read_npz(npz)
    size = f"{result.num_persons} person(s) x {result.num_hypotheses} hypotheses x {result.num_frames} frames"
    lines = [f"{size} ({result.frame_times[-1] - result.frame_times[0]:.2f} s) seen by {len(result.cameras)} camera(s)"]
    for p, track in enumerate(result.track_ids):
        on = result.present()[p]
        spread = np.linalg.norm(result.hypotheses[p][:, on] - result.median[p][on], axis=-1).mean() * 1000
        pelvis = np.median(result.median[p][on, 0, 2])
        lines.append(
            f"  person {track}: present in {on.sum()} frames, pelvis {pelvis:.2f} m above the floor, "
            f"hypotheses within {spread:.0f} mm of the median on average"
        )
    return lines


@settings_options("prior", only=("path",))
@settings_options("sampler", only=("samples",), defaults={"samples": 20})
def demo(
    out: Path = typer.Option(Path("out/demo"), "--out", help="Output folder."),
    source: str = typer.Option(
        "videos", "--source", help="videos: detect in cam01 + cam02; keypoints: the shipped OpenPose 2D of 4 views."
    ),
    threads: int | None = typer.Option(
        None, "--threads", min=1, help="torch and onnxruntime threads (default: 1, as lift)."
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars."),
    prior: PriorSettings = None,
    sampler: SamplerConfig = None,
) -> None:
    """Lift the bundled Pose2Sim balancing take (real lab videos, 4-camera calibration) and say where the files are."""
    from platypose.cli.commands_lift import finish, lift_settings
    from platypose.cli.runs.batch import run_batch
    from platypose.lifting.settings import DetectOptions, WindowSettings

    take = demo_take()
    job = demo_job(take, source)
    typer.echo(f"demo: {job.input} with {take / 'calib_pose2sim.toml'}")
    arguments = {"command": "demo", "source": source, "samples": sampler.samples, "prior": as_json(prior.path)}
    calibration = take / "calib_pose2sim.toml"
    detect = DetectOptions(threads=threads)
    settings = lift_settings(
        out=out,
        cams=calibration,
        prior=prior,
        detect=detect,
        sampler=sampler,
        windows=WindowSettings(),
        formats="npz,csv,bvh,rrd",
        persons="largest",
        root="auto",
        root_file=None,
        quiet=quiet,
        arguments=arguments,
    )
    entries = run_batch([job], settings, say=lambda m: None if quiet else typer.echo(m, err=True))
    if entries[0]["status"] == "ok":
        typer.echo("\n".join(describe(out / job.name / f"{job.name}.npz")))
    finish(entries, out)
