"""``platypose train``: train a motion prior on real motion files."""

from __future__ import annotations

from pathlib import Path

import typer

from platypose.cli.terminal.options import settings_options
from platypose.lifting.settings import DistilConfig, PriorArchitecture, TrainConfig


@settings_options("train", parameter="optimisation", given_only=True)
@settings_options("distil", only=("calls",))
@settings_options("architecture", panel=None, in_place=True)
def train(
    *,
    data: list[Path] = typer.Argument(
        ..., help="Motion files or folders (BVH, ASF/AMC, npy, DeepMimic, npz, C3D), or one motion pack (--pack)."
    ),
    out: Path = typer.Option(
        None, "--out", help="Checkpoint to write (periodically, atomically; over 16 MiB in pieces beside it)."
    ),
    pack: Path = typer.Option(
        None, "--pack", help="Instead of training, write DATA (less --hold-out) packed small into this one .npz file."
    ),
    device: str = typer.Option("cpu", help="Train on cpu, cuda, or auto (cuda when torch sees a GPU)."),
    precision: str = typer.Option(
        "auto", help="Forward passes in float32 or bfloat16 (autocast); auto: bfloat16 on cuda, float32 on cpu."
    ),
    architecture: PriorArchitecture = None,
    resume: bool = typer.Option(False, "--resume", help="Continue from the checkpoint at --out."),
    threads: int = typer.Option(0, help="Torch threads (0: torch's default)."),
    log_file: Path = typer.Option(None, help="Also append JSON lines of losses here."),
    distil_from: Path = typer.Option(
        None,
        "--distil-from",
        help="Distil this prior into a student of --calls network calls (half its own), trained on its training "
        "clips among DATA; the architecture options do not apply.",
    ),
    hold_out: Path = typer.Option(
        None,
        "--hold-out",
        help="JSON file of unseen sets (data/motion/unseen.json): their files are left out of DATA (docs/prior.md).",
    ),
    quiet: bool = typer.Option(False, "--quiet", help="No progress output."),
    optimisation: dict = None,
    distil: DistilConfig = None,
) -> None:
    """Train a motion prior (x0-predicting transformer) on real 3D motion, or distil one into fewer calls."""
    from platypose.lifting.offline.train_run import TrainRun, distil_settings, network_of, run_training

    network = network_of(architecture)
    run = TrainRun(
        data=tuple(data),
        out=out,
        pack=pack,
        network=network,
        config=TrainConfig(**optimisation),
        distil=distil_settings(optimisation, distil),
        distil_from=distil_from,
        hold_out=hold_out,
        resume=resume,
        device=device,
        precision=precision,
        threads=threads,
        log_file=log_file,
    )
    run_training(run, say=None if quiet else lambda line: typer.echo(line, err=True))


def prior_info(prior: Path = typer.Argument(None, help="Checkpoint (default: the shipped prior).")) -> None:
    """Print a prior's size, frame rate, training data and the licence of every clip."""
    from dataclasses import asdict

    from platypose.lifting.prior.model import DEFAULT_PRIOR, load_prior

    bundle, _ = load_prior(prior)
    manifest = bundle.manifest
    typer.echo(f"prior {prior or DEFAULT_PRIOR} (sha256 {bundle.checksum[:16]})")
    typer.echo("config: " + ", ".join(f"{k}={v}" for k, v in asdict(bundle.config).items()))
    params = sum(p.numel() for p in bundle.model.parameters())
    typer.echo(
        f"parameters: {params:,}; trained {manifest.get('iterations', '?')} iterations on "
        f"{manifest.get('train_seconds', 0) / 60:.1f} min of motion"
    )
    distilled = manifest.get("distilled")
    if distilled:
        typer.echo(
            f"distilled from {distilled['teacher_sha256'][:16]} ({len(distilled['teacher_steps'])} calls) in "
            f"{distilled['iterations']} iterations: {len(bundle.fixed_steps)} calls at steps "
            + ", ".join(map(str, bundle.fixed_steps))
        )
    typer.echo("licences: " + ", ".join(manifest.get("licences", [])))
    for clip in manifest.get("clips", []):
        typer.echo(f"  {clip['split']:10s} {clip['frames']:6d} frames  {clip['licence']:20s} {clip['name']}")
