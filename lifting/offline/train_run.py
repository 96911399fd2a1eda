"""A training run from files, as ``platypose train`` asks for one: DATA (less the files of a hold-out file's unseen
sets) packed into one motion pack, a prior trained or resumed, or a teacher distilled into fewer network calls.

Files are read and the checkpoint, the pack and the loss log written here; the lines a person reads (what is done,
the losses as they come) are said through ``say``, and bad input is an InputError naming the option or file.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

from platypose.lifting.errors import InputError
from platypose.lifting.prior.model import PriorConfig
from platypose.lifting.settings import DistilConfig, PriorArchitecture, TrainConfig

PRECISIONS = ("auto", "float32", "bfloat16")


@dataclass(frozen=True)
class TrainRun:
    """What one run is asked for: ``out`` (a checkpoint to train, ``resume`` it, or distil ``distil_from`` into)
    or ``pack`` (a motion pack to write), from ``data`` less the unseen sets of ``hold_out``; the ``network`` to
    build, the optimisation ``config`` or ``distil``, the torch ``device`` (cpu, cuda, auto), the ``precision`` of
    forward passes (auto, float32, bfloat16), torch ``threads`` (0: torch's default), a ``log_file`` of losses."""

    data: tuple[Path, ...]
    out: Path | None = None
    pack: Path | None = None
    network: PriorConfig = field(default_factory=PriorConfig)
    config: TrainConfig = field(default_factory=TrainConfig)
    distil: DistilConfig = field(default_factory=DistilConfig)
    distil_from: Path | None = None
    hold_out: Path | None = None
    resume: bool = False
    device: str = "cpu"
    precision: str = "auto"
    threads: int = 0
    log_file: Path | None = None


def network_of(architecture: PriorArchitecture) -> PriorConfig:
    """The network ``architecture`` asks for, checked; InputError saying what is wrong."""
    try:
        return PriorConfig(**asdict(architecture))
    except ValueError as err:
        raise InputError(f"train: {err}") from None


def distil_settings(optimisation: Mapping[str, object], distil: DistilConfig) -> DistilConfig:
    """``distil`` with the optimisation values given (``optimisation``: option -> value) that distillation shares;
    it validates at least as often as it writes a checkpoint."""
    shared = {k: v for k, v in optimisation.items() if k in {f.name for f in fields(DistilConfig)}}
    if "checkpoint_every" in shared:
        shared["validate_every"] = min(distil.validate_every, shared["checkpoint_every"])
    return replace(distil, **shared)


def run_training(run: TrainRun, say: Callable[[str], None] | None = None) -> None:
    """Do ``run``: write the pack, or train (resume, distil) the checkpoint; ``say`` each line a person reads
    (None: silent). InputError, before anything is written, for a value or file that cannot be used."""
    from platypose.lifting.files.atomic import check_writable
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.motion_pack import write_pack

    iterations = (run.config if run.distil_from is None else run.distil).iterations
    if run.threads < 0:
        raise InputError(f"train: --threads must be 0 (torch's default) or more, got {run.threads}")
    if run.precision not in PRECISIONS:
        raise InputError(f"train: --precision must be auto, float32 or bfloat16, got {run.precision!r}")
    if (run.out is None) == (run.pack is None):
        raise InputError("train: give --out (a checkpoint to train) or --pack (a motion pack to write), not both")
    data = list(run.data)
    if run.hold_out is not None:
        from platypose.lifting.offline.unseen_sets import load_sets, without_sets

        data = without_sets(data, load_sets(run.hold_out))
    if run.pack is not None:
        check_writable(run.pack)
        motions = load_motion_paths(data)
        fps = run.network.fps
        frames = write_pack(motions, run.pack, fps)
        if say:
            say(f"packed {len(motions)} clips, {frames / fps / 60:.1f} min at {fps:g} fps into {run.pack}")
        return
    _train(run, data, iterations, say)


def _train(run: TrainRun, data: list[Path], iterations: int, say: Callable[[str], None] | None) -> None:
    """:func:`run_training` of a checkpoint (``run.out``) from the files ``data``."""
    from platypose.lifting.files.atomic import check_writable, same_file
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.distillation import distil_prior
    from platypose.lifting.offline.motion_pack import is_pack, read_pack
    from platypose.lifting.offline.training import TrainingDiverged, train_prior
    from platypose.lifting.prior.model import load_prior
    from platypose.lifting.prior.runtime import resolve_device
    from platypose.lifting.sampling.sampler import network_steps
    from platypose.lifting.settings import SamplerConfig

    out, distil_from = run.out, run.distil_from
    torch_device = resolve_device(run.device)
    bfloat16 = run.precision == "bfloat16" or (run.precision == "auto" and torch_device.type == "cuda")
    if distil_from is not None and same_file(out, distil_from):  # before check_writable refuses a link by itself
        raise InputError(f"--out {out}: is the teacher given by --distil-from; it would be overwritten")
    check_writable(out)
    if run.log_file is not None:
        check_writable(run.log_file)
    teacher = load_prior(distil_from)[0] if distil_from is not None else None
    motions = read_pack(data[0]) if len(data) == 1 and is_pack(data[0]) else load_motion_paths(data)
    if not motions:
        raise InputError(f"{', '.join(map(str, data))}: no motion files found")
    network, resume_state = run.network, None
    if run.resume:
        bundle, resume_state = load_prior(out)
        if not resume_state:
            raise InputError(f"{out}: checkpoint holds no training state (finished or not resumable)")
        distilled_from = bundle.manifest.get("distilled", {}).get("teacher_sha256")
        if teacher is not None and distilled_from != teacher.checksum:
            raise InputError(f"{out}: checkpoint was not distilled from {distil_from}; cannot resume it")
        network = bundle.config
        if say:
            say(f"resuming {out} at iteration {resume_state['iteration']} of {iterations}")
    if say:
        seconds = sum(m.duration_s for m in motions)
        say(f"training on {len(motions)} clips, {seconds / 60:.1f} min of motion")
    log = losses_log(run.log_file, say, iterations, (resume_state or {}).get("iteration", 0))
    threads = run.threads or None
    began = time.time()
    try:
        if teacher is None:
            train_prior(
                motions,
                str(out),
                network,
                run.config,
                resume=resume_state,
                log=log,
                threads=threads,
                device=torch_device,
                bfloat16=bfloat16,
            )
        else:
            steps = network_steps(teacher, SamplerConfig())
            try:
                distil_prior(motions, teacher, steps, str(out), run.distil, resume_state, log, threads)
            except ValueError as err:
                raise InputError(f"{distil_from}: {err}") from None
    except TrainingDiverged as err:
        raise InputError(f"{out}: {err}") from None
    if say:
        say(f"wrote {out} after {(time.time() - began) / 60:.1f} min")


def losses_log(
    path: Path | None, say: Callable[[str], None] | None, iterations: int, started_at: int
) -> Callable[[dict], None]:
    """The log training calls with each validation's entry: a JSON line appended to ``path``, and a line said with
    the losses, the time spent and the time left (of ``iterations``, the run having started at ``started_at``)."""

    def log(entry: dict) -> None:
        if path:
            with open(path, "a") as fh:
                fh.write(json.dumps(entry) + "\n")
        if say:
            done = entry["iteration"]
            eta = entry["seconds"] / max(done - started_at, 1) * (iterations - done)
            say(
                f"[{done}/{iterations}] train {entry['train_loss']:.4f} val {entry['val_loss']:.4f} "
                f"elapsed {entry['seconds'] / 60:.1f} min, left ~{eta / 60:.1f} min"
            )

    return log
