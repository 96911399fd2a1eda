"""Progressive distillation of the x0 predictor: a student that does two of its teacher's DDIM steps in one call.

The teacher samples at steps ``s_0 > s_1 > ... > s_{2n-1}`` (8 network calls by default). The
student, initialised from the teacher, is called at ``s_0, s_2, ..., s_{2n-2}`` only and learns,
for a noisy window ``x_t`` at ``s_{2i}``, the prediction that one DDIM step re-noises to where
the teacher's two DDIM steps (``s_{2i} -> s_{2i+1} -> s_{2i+2}``) land; at the last pair, the
teacher's final prediction itself (Salimans & Ho 2022). Guidance stays between the student's calls,
as between the teacher's. The student's checkpoint keeps the teacher's normalisation and data
manifest, and records the steps it was trained for (:attr:`PriorBundle.fixed_steps`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict

import numpy as np
import torch

from platypose.lifting.errors import InputError
from platypose.lifting.motion import Motion
from platypose.lifting.offline.training import (
    TrainingDiverged,
    WindowSampler,
    cosine_rate,
    prepare_clips,
    take_step,
)
from platypose.lifting.prior.features import joints_to_features
from platypose.lifting.prior.model import MotionPrior, PriorBundle, save_prior
from platypose.lifting.prior.schedule import DiffusionSchedule
from platypose.lifting.settings import DistilConfig, TrainConfig

END = -1  # "no next step": the pair ends the sampling


def halving_plan(teacher_steps: Sequence[int], calls: int) -> np.ndarray:
    """Rows ``(student step, teacher's middle step, next student step or END)`` ``(calls, 3)`` for a halving."""
    steps = [int(s) for s in teacher_steps]
    if len(steps) != 2 * calls:
        raise ValueError(
            f"a student makes half its teacher's network calls: the teacher makes {len(steps)}, "
            f"so --calls must be {len(steps) // 2}" + ("" if len(steps) % 2 == 0 else " (and the teacher's are odd)")
        )
    following = [*steps[2::2], END]
    return np.array([[steps[2 * i], steps[2 * i + 1], following[i]] for i in range(calls)], dtype=np.int64)


def two_step_target(
    teacher: MotionPrior, schedule: DiffusionSchedule, x_t: torch.Tensor, plan_rows: torch.Tensor
) -> torch.Tensor:
    """The prediction a student should make for ``x_t`` ``(B, F, D)``: two teacher DDIM steps in one.

    ``plan_rows`` ``(B, 3)`` holds each row's (step, middle step, next step or END).
    """
    t, middle, following = plan_rows.unbind(1)
    with torch.inference_mode():
        x_middle = schedule.ddim_step(x_t, teacher(x_t, t), t, middle)
        x0_middle = teacher(x_middle, middle)
        ends = following == END
        landing = following.clamp(min=0)
        x_next = schedule.ddim_step(x_middle, x0_middle, middle, landing)
        one_step = schedule.ddim_prediction(x_t, x_next, t, landing)
        target = torch.where(ends[:, None, None], x0_middle, one_step)
    return target.clone()


def teacher_clips(motions: Sequence[Motion], teacher: PriorBundle) -> tuple[list, list]:
    """The teacher's training and validation clips among ``motions``, by its manifest (all clips if it has none)."""
    clips = prepare_clips(motions, teacher.fps, min_frames=2)
    split = {c["name"]: c["split"] for c in teacher.manifest.get("clips", [])}
    if not split:
        return clips, []
    train = [c for c in clips if split.get(c.name) == "train"]
    validation = [c for c in clips if split.get(c.name) == "validation"]
    if not train:
        raise InputError("none of the teacher's training clips (its manifest) is among the motion files given")
    return train, validation


def distil_prior(
    motions: Sequence[Motion],
    teacher: PriorBundle,
    teacher_steps: Sequence[int],
    out_path: str,
    config: DistilConfig,
    resume: dict | None = None,
    log: Callable[[dict], None] | None = None,
    threads: int | None = None,
) -> PriorBundle:
    """Distil ``teacher`` (sampling at ``teacher_steps``) into a student of ``config.calls`` calls at ``out_path``.

    Trains on the teacher's own training clips with its augmentation; validates on its held-out
    clips. Checkpoints are written atomically every ``checkpoint_every`` steps with the state to
    resume from (``resume``: a checkpoint's ``extra``); the last one without it. ``log`` receives
    dicts with iteration, losses and elapsed seconds.
    """
    if threads:
        torch.set_num_threads(threads)
    plan = halving_plan(teacher_steps, config.calls)
    train, validation = teacher_clips(motions, teacher)
    recorded = teacher.manifest.get("train_config", {})
    recorded = {k: tuple(v) if isinstance(v, list) else v for k, v in recorded.items()}
    augment = TrainConfig(**{**recorded, "seed": config.seed})  # the teacher's augmentation
    rng = np.random.default_rng(config.seed)
    frames_max = teacher.config.max_frames
    sampler = WindowSampler(train, frames_max, augment, rng)
    val_rng = np.random.default_rng(config.seed + 1)
    val_sampler = WindowSampler(validation or train, frames_max, augment, val_rng)
    schedule = DiffusionSchedule(teacher.config.diffusion_steps)
    teacher.model.eval()
    student = MotionPrior(teacher.config)
    student.load_state_dict(teacher.model.state_dict())
    student.eval()  # trained without dropout too: it matches a deterministic teacher
    optimiser = torch.optim.AdamW(student.parameters(), lr=config.learning_rate, weight_decay=0.0)
    start = 0
    if resume:
        student.load_state_dict(resume["model"], strict=True)
        optimiser.load_state_dict(resume["optimiser"])
        start = int(resume["iteration"])
        rng.bit_generator.state = resume["rng"]
    plan_t = torch.as_tensor(plan)

    def draw(windows: np.ndarray, rows: np.ndarray, starts: np.ndarray, gen: torch.Generator) -> tuple:
        x0 = torch.as_tensor(teacher.normalizer.normalize(joints_to_features(windows)), dtype=torch.float32)
        x0 = torch.where(torch.as_tensor(starts)[:, None, None], torch.zeros_like(x0), x0)
        steps = plan_t[torch.as_tensor(rows)]
        x_t = schedule.add_noise(x0, steps[:, 0], torch.randn(x0.shape, generator=gen))
        return x_t, steps, two_step_target(teacher.model, schedule, x_t, steps)

    val_rows = np.arange(256) % config.calls
    val_x, val_steps, val_target = draw(
        val_sampler.batch(256, frames_max), val_rows, np.zeros(256, bool), torch.Generator().manual_seed(config.seed)
    )
    manifest = {
        **teacher.manifest,
        "sampling_steps": plan[:, 0].tolist(),
        "distilled": {
            "teacher_sha256": teacher.checksum,
            "teacher_steps": [int(s) for s in teacher_steps],
            "config": asdict(config),
            "iterations": start,
        },
    }
    bundle = PriorBundle(student, teacher.normalizer, manifest)

    def validate() -> float:
        with torch.no_grad():
            return float(((student(val_x, val_steps[:, 0]) - val_target) ** 2).mean())

    def checkpoint(done: int) -> None:
        if not all(bool(torch.isfinite(p).all()) for p in student.parameters()):
            raise TrainingDiverged(f"distillation diverged before iteration {done}: the weights hold NaN or infinities")
        extra = {"iteration": done, "model": student.state_dict(), "optimiser": optimiser.state_dict()}
        extra["rng"] = rng.bit_generator.state
        bundle.manifest["distilled"]["iterations"] = done
        save_prior(out_path, bundle, extra=extra if done < config.iterations else None)

    began = time.time()
    running = None
    if log and start == 0:
        log({"iteration": 0, "train_loss": validate(), "val_loss": validate(), "seconds": 0.0})
    for it in range(start, config.iterations):
        frames = int(rng.integers(1, frames_max + 1))
        rows = rng.integers(0, config.calls, size=config.batch_size)
        starts = (rows == 0) & (rng.random(config.batch_size) < config.start_share)
        generator = torch.Generator().manual_seed(config.seed * 1_000_003 + it)  # a resumed run draws the same
        x_t, steps, target = draw(sampler.batch(config.batch_size, frames), rows, starts, generator)
        loss = ((student(x_t, steps[:, 0]) - target) ** 2).mean()
        if not torch.isfinite(loss):
            raise TrainingDiverged(f"distillation diverged at iteration {it + 1}: the loss is {loss.item()}")
        take_step(student, optimiser, loss, cosine_rate(config.learning_rate, it, config.iterations, warmup=100))
        running = loss.item() if running is None else 0.98 * running + 0.02 * loss.item()
        done = it + 1
        if log and (done % config.validate_every == 0 or done == config.iterations):
            log({"iteration": done, "train_loss": running, "val_loss": validate(), "seconds": time.time() - began})
        if done % config.checkpoint_every == 0 or done == config.iterations:
            checkpoint(done)
    return bundle
