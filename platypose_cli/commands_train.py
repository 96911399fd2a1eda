"""``platypose train``: train a motion prior on real motion files."""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, fields, replace
from pathlib import Path

import typer

from platypose.cli.terminal.options import settings_options
from platypose.lifting.errors import InputError
from platypose.lifting.settings import DistilConfig, PriorArchitecture, TrainConfig


@settings_options("train", parameter="optimisation", given_only=True)
@settings_options("distil", only=("calls",))
@settings_options("architecture", panel=None, in_place=True)
def train(
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
    from platypose.lifting.files.atomic import check_writable, same_file
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.distillation import distil_prior
    from platypose.lifting.offline.motion_pack import is_pack, read_pack, write_pack
    from platypose.lifting.offline.training import TrainingDiverged, train_prior
    from platypose.lifting.prior.model import PriorConfig, load_prior
    from platypose.lifting.prior.runtime import resolve_device
    from platypose.lifting.sampling.sampler import network_steps
    from platypose.lifting.settings import SamplerConfig

    try:
        prior_config = PriorConfig(**asdict(architecture))
    except ValueError as err:
        raise InputError(f"train: {err}") from None
    config = TrainConfig(**optimisation)
    shared = {k: v for k, v in optimisation.items() if k in {f.name for f in fields(DistilConfig)}}
    if "checkpoint_every" in shared:
        shared["validate_every"] = min(distil.validate_every, shared["checkpoint_every"])
    distil = replace(distil, **shared)
    iterations = (config if distil_from is None else distil).iterations
    if threads < 0:
        raise InputError(f"train: --threads must be 0 (torch's default) or more, got {threads}")
    if precision not in ("auto", "float32", "bfloat16"):
        raise InputError(f"train: --precision must be auto, float32 or bfloat16, got {precision!r}")
    if (out is None) == (pack is None):
        raise InputError("train: give --out (a checkpoint to train) or --pack (a motion pack to write), not both")
    if hold_out is not None:
        from platypose.lifting.offline.unseen_sets import load_sets, without_sets

        data = without_sets(data, load_sets(hold_out))
    if pack is not None:
        check_writable(pack)
        motions = load_motion_paths(data)
        frames = write_pack(motions, pack, architecture.fps)
        if not quiet:
            typer.echo(
                f"packed {len(motions)} clips, {frames / architecture.fps / 60:.1f} min at {architecture.fps:g} fps into {pack}",
                err=True,
            )
        return
    torch_device = resolve_device(device)
    bfloat16 = precision == "bfloat16" or (precision == "auto" and torch_device.type == "cuda")
    if distil_from is not None and same_file(out, distil_from):  # before check_writable refuses a link by itself
        raise InputError(f"--out {out}: is the teacher given by --distil-from; it would be overwritten")
    check_writable(out)
    if log_file is not None:
        check_writable(log_file)
    teacher = load_prior(distil_from)[0] if distil_from is not None else None
    motions = read_pack(data[0]) if len(data) == 1 and is_pack(data[0]) else load_motion_paths(data)
    if not motions:
        raise InputError(f"{', '.join(map(str, data))}: no motion files found")
    resume_state = None
    if resume:
        bundle, resume_state = load_prior(out)
        if not resume_state:
            raise InputError(f"{out}: checkpoint holds no training state (finished or not resumable)")
        distilled_from = bundle.manifest.get("distilled", {}).get("teacher_sha256")
        if teacher is not None and distilled_from != teacher.checksum:
            raise InputError(f"{out}: checkpoint was not distilled from {distil_from}; cannot resume it")
        prior_config = bundle.config
        if not quiet:
            typer.echo(f"resuming {out} at iteration {resume_state['iteration']} of {iterations}", err=True)
    if not quiet:
        seconds = sum(m.duration_s for m in motions)
        typer.echo(f"training on {len(motions)} clips, {seconds / 60:.1f} min of motion", err=True)

    def log(entry: dict) -> None:
        if log_file:
            with open(log_file, "a") as fh:
                fh.write(json.dumps(entry) + "\n")
        if not quiet:
            done = entry["iteration"]
            eta = entry["seconds"] / max(done - (resume_state or {}).get("iteration", 0), 1) * (iterations - done)
            print(
                f"[{done}/{iterations}] train {entry['train_loss']:.4f} val {entry['val_loss']:.4f} "
                f"elapsed {entry['seconds'] / 60:.1f} min, left ~{eta / 60:.1f} min",
                file=sys.stderr,
                flush=True,
            )

    began = time.time()
    try:
        if teacher is None:
            train_prior(
                motions,
                str(out),
                prior_config,
                config,
                resume=resume_state,
                log=log,
                threads=threads or None,
                device=torch_device,
                bfloat16=bfloat16,
            )
        else:
            steps = network_steps(teacher, SamplerConfig())
            try:
                distil_prior(motions, teacher, steps, str(out), distil, resume_state, log, threads or None)
            except ValueError as err:
                raise InputError(f"{distil_from}: {err}") from None
    except TrainingDiverged as err:
        raise InputError(f"{out}: {err}") from None
    if not quiet:
        typer.echo(f"wrote {out} after {(time.time() - began) / 60:.1f} min", err=True)


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
