"""Training the motion prior: windows from real clips, augmentation, the x0 loss, checkpoints.

Algorithm 2 of the paper: sample a clean window, a step t ~ U(0, T-1) and a
length f ~ U(1, F_max) (one per batch), noise it and regress x0 with an L2
loss. Augmentation: random yaw, mirror with left/right swap, time scaling and
bone-length scaling (symmetric per bone pair plus a global factor).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np
import torch

from platypose.lifting.errors import InputError
from platypose.lifting.motion import Motion
from platypose.lifting.prior.features import Normalizer, joints_to_features
from platypose.lifting.prior.model import MotionPrior, PriorBundle, PriorConfig, save_prior
from platypose.lifting.prior.schedule import DiffusionSchedule
from platypose.lifting.settings import TrainConfig
from platypose.lifting.skeleton import MIRROR, PARENTS, mirror_joints
from platypose.lifting.timebase import interpolate, resample


class TrainingDiverged(ValueError):
    """The data's statistics, the training loss or the weights became NaN or infinite; nothing more is written."""


@dataclass(frozen=True)
class Clip:
    """A clip resampled to the prior's rate: ``joints`` (T, 17, 3)."""

    joints: np.ndarray
    name: str
    source: str
    licence: str
    original_fps: float


def prepare_clips(motions: Sequence[Motion], fps: float, min_frames: int = 2) -> list[Clip]:
    """Resample every motion to ``fps``; drops clips shorter than ``min_frames`` and any frame with NaN."""
    clips = []
    for m in motions:
        joints = m.joints[np.isfinite(m.joints).all(axis=(1, 2))]
        joints = resample(joints, m.fps, fps)
        if len(joints) >= min_frames:
            clips.append(Clip(joints, m.name, m.source, m.licence, m.extra.get("original_fps", m.fps)))
    return clips


def split_clips(clips: list[Clip], fraction: float, seed: int) -> tuple[list[Clip], list[Clip]]:
    """Hold out whole clips (about ``fraction`` of all frames) for validation; at least one clip stays in training."""
    order = np.random.default_rng(seed).permutation(len(clips))
    total = sum(len(c.joints) for c in clips)
    held, frames = [], 0
    for i in order[:-1]:
        if frames >= fraction * total:
            break
        held.append(int(i))
        frames += len(clips[i].joints)
    train = [c for i, c in enumerate(clips) if i not in held]
    return train, [clips[i] for i in held]


def yaw_rotation(angles: np.ndarray) -> np.ndarray:
    """Rotation matrices about Z for angles ``(B,)`` radians -> ``(B, 3, 3)``."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler("z", np.asarray(angles, dtype=np.float64).reshape(-1, 1)).as_matrix()


def scale_bones(joints: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """Rebuild joints ``(B, F, 17, 3)`` with every bone (child of joint j) scaled by ``scales[:, j]`` ``(B, 17)``."""
    out = joints.copy()
    for j, p in enumerate(PARENTS):
        if p >= 0:
            out[:, :, j] = out[:, :, p] + (joints[:, :, j] - joints[:, :, p]) * scales[:, None, j, None]
    return out


class WindowSampler:
    """Draws augmented training windows ``(B, F, 17, 3)`` from clips, frames weighted uniformly."""

    def __init__(self, clips: list[Clip], frames: int, config: TrainConfig, rng: np.random.Generator) -> None:
        self.clips, self.frames, self.config, self.rng = clips, frames, config, rng
        lengths = np.array([len(c.joints) for c in clips], dtype=np.float64)
        self.weights = lengths / lengths.sum()

    def window(self, frames: int, time_scale: float) -> np.ndarray:
        """One window of ``frames`` frames read at ``time_scale`` times the clip's speed ``(F, 17, 3)``."""
        clip = self.clips[self.rng.choice(len(self.clips), p=self.weights)].joints
        span = (frames - 1) * time_scale
        if span > len(clip) - 1:  # a short clip: slow it down at most to 2/3 speed, then hold its last frame
            time_scale = max((len(clip) - 1) / max(frames - 1, 1), 2 / 3)
            span = (frames - 1) * time_scale
        start = self.rng.uniform(0, max(len(clip) - 1 - span, 0.0))
        return interpolate(clip, np.arange(len(clip)), start + np.arange(frames) * time_scale)

    def batch(self, size: int, frames: int) -> np.ndarray:
        """A batch of augmented windows ``(B, F, 17, 3)``."""
        c, rng = self.config, self.rng
        scales = rng.uniform(*c.time_scale, size=size)
        joints = np.stack([self.window(frames, s) for s in scales])
        per_joint = rng.uniform(1 - c.bone_scale, 1 + c.bone_scale, size=(size, 17))
        symmetric = per_joint[:, np.minimum(np.arange(17), np.array(MIRROR))]  # one factor per left/right pair
        bone = symmetric * rng.uniform(1 - c.global_scale, 1 + c.global_scale, size=(size, 1))
        joints = scale_bones(joints, bone)
        flip = rng.random(size) < c.mirror_probability
        joints[flip] = mirror_joints(joints[flip])
        rotation = yaw_rotation(rng.uniform(0, 2 * np.pi, size=size))
        return np.einsum("bij,bfkj->bfki", rotation, joints - joints[:, :1, :1])


def fit_normalizer(sampler: WindowSampler, frames: int, windows: int = 2048) -> Normalizer:
    """Normalisation statistics from augmented full-length windows."""
    return Normalizer.fit(joints_to_features(sampler.batch(windows, frames)))


def manifest_of(train: list[Clip], validation: list[Clip], config: TrainConfig, prior_config: PriorConfig) -> dict:
    """The data manifest stored in the checkpoint: every clip's source, frames and licence."""

    def entry(c: Clip, split: str) -> dict:
        return {
            "name": c.name,
            "source": c.source,
            "licence": c.licence,
            "frames": len(c.joints),
            "original_fps": float(c.original_fps),
            "split": split,
        }

    clips = [entry(c, "train") for c in train] + [entry(c, "validation") for c in validation]
    return {
        "clips": clips,
        "licences": sorted({c.licence for c in train + validation}),
        "train_seconds": sum(len(c.joints) for c in train) / prior_config.fps,
        "train_config": asdict(config),
    }


def take_step(model: torch.nn.Module, optimiser: torch.optim.Optimizer, loss: torch.Tensor, rate: float) -> None:
    """One optimiser step on ``loss`` at learning rate ``rate``, the gradients clipped to norm 1."""
    for group in optimiser.param_groups:
        group["lr"] = rate
    optimiser.zero_grad(set_to_none=True)
    loss.backward()
    torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
    optimiser.step()


def cosine_rate(peak: float, iteration: int, iterations: int, warmup: int) -> float:
    """Learning rate at ``iteration``: linear warm-up over ``warmup`` steps, then cosine decay to 0 at ``iterations``.

    A plain float (a numpy scalar would make the checkpoint's optimiser state unloadable with weights_only).
    """
    ramp = min(1.0, (iteration + 1) / warmup)
    return float(peak * ramp * 0.5 * (1 + np.cos(np.pi * min(iteration / iterations, 1.0))))


def train_prior(
    motions: Sequence[Motion],
    out_path: str,
    prior_config: PriorConfig,
    config: TrainConfig,
    resume: dict | None = None,
    log: Callable[[dict], None] | None = None,
    threads: int | None = None,
    device: str | torch.device = "cpu",
    bfloat16: bool = False,
) -> PriorBundle:
    """Train (or resume) a prior on ``motions`` and write checkpoints to ``out_path``; returns the final bundle.

    ``resume`` is the ``extra`` dict of a checkpoint (optimiser state, iteration, both RNG states): a resumed
    run ends with the same weights as one never interrupted.
    ``log`` receives dicts with iteration, losses and elapsed seconds. Raises :class:`TrainingDiverged`
    (before writing anything of that step) when the loss is not finite. ``device``: where the network trains
    (windows, steps and noise are drawn on the CPU as always, then moved there); ``bfloat16``: its forward passes
    under bfloat16 autocast (the loss, weights and optimiser stay float32).
    """
    if threads:
        torch.set_num_threads(threads)
    rng = np.random.default_rng(config.seed)
    torch.manual_seed(config.seed)
    clips = prepare_clips(motions, prior_config.fps, min_frames=2)
    if not clips:
        raise InputError(f"no motion clip of at least 2 frames at {prior_config.fps:g} fps to train on")
    train, validation = split_clips(clips, config.validation_fraction, config.seed)
    F = prior_config.max_frames
    sampler = WindowSampler(train, F, config, rng)
    val_sampler = WindowSampler(validation or train, F, config, np.random.default_rng(config.seed + 1))
    device = torch.device(device)
    model = MotionPrior(prior_config).to(device)
    optimiser = torch.optim.AdamW(model.parameters(), lr=config.learning_rate, weight_decay=config.weight_decay)
    start, running = 0, None
    if resume:
        normalizer = Normalizer(np.asarray(resume["normalizer_mean"]), np.asarray(resume["normalizer_std"]))
        model.load_state_dict(resume["model"], strict=True)
        optimiser.load_state_dict(resume["optimiser"])
        start = int(resume["iteration"])
        rng.bit_generator.state = resume["rng"]
        if "torch_rng" in resume:  # checkpoints before it was saved resume on a fresh noise stream
            torch.set_rng_state(resume["torch_rng"])
        running = resume.get("running")  # the logged loss average goes on where it was
        if "cuda_rng" in resume and device.type == "cuda":
            torch.cuda.set_rng_state(resume["cuda_rng"].cpu())
    else:
        normalizer = fit_normalizer(sampler, F)
    if not (np.isfinite(normalizer.mean).all() and np.isfinite(normalizer.std).all()):
        raise TrainingDiverged("the motion data gives NaN or infinite feature statistics (a corrupt clip?)")
    bundle = PriorBundle(model, normalizer, manifest_of(train, validation, config, prior_config))
    schedule = DiffusionSchedule(prior_config.diffusion_steps)
    val_batch = torch.as_tensor(
        normalizer.normalize(joints_to_features(val_sampler.batch(256, F))), dtype=torch.float32
    )
    val_gen = torch.Generator().manual_seed(config.seed)
    val_t = torch.randint(0, prior_config.diffusion_steps, (len(val_batch),), generator=val_gen)
    val_noise = torch.randn(val_batch.shape, generator=val_gen)
    val_batch, val_t, val_noise = val_batch.to(device), val_t.to(device), val_noise.to(device)

    def predict(x_t: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        with torch.autocast(device.type, dtype=torch.bfloat16, enabled=bfloat16):
            return model(x_t, t).float()

    def checkpoint(it: int) -> None:
        if not all(bool(torch.isfinite(p).all()) for p in model.parameters()):
            raise TrainingDiverged(f"training diverged before iteration {it}: the weights hold NaN or infinite values")
        extra = {
            "iteration": it,
            "model": model.state_dict(),
            "optimiser": optimiser.state_dict(),
            "normalizer_mean": normalizer.mean.tolist(),
            "normalizer_std": normalizer.std.tolist(),
            "rng": rng.bit_generator.state,
            "torch_rng": torch.get_rng_state(),  # diffusion steps, noise and dropout: resuming repeats them exactly
            "running": running,
        }
        if device.type == "cuda":
            extra["cuda_rng"] = torch.cuda.get_rng_state()  # dropout on the GPU
        bundle.manifest["iterations"] = it
        save_prior(out_path, bundle, extra=extra if it < config.iterations else None)

    began = time.time()
    for it in range(start, config.iterations):
        model.train()
        frames = int(rng.integers(1, F + 1))
        x0 = torch.as_tensor(
            normalizer.normalize(joints_to_features(sampler.batch(config.batch_size, frames))), dtype=torch.float32
        )
        t = torch.randint(0, prior_config.diffusion_steps, (config.batch_size,))
        noise = torch.randn_like(x0)
        x0, t = x0.to(device), t.to(device)
        x_t = schedule.add_noise(x0, t, noise.to(device))
        loss = ((predict(x_t, t) - x0) ** 2).mean()
        if not torch.isfinite(loss):
            raise TrainingDiverged(
                f"training diverged at iteration {it + 1}: the loss is {loss.item()} "
                f"(lower the learning rate, or check the motion data); the last checkpoint written stays"
            )
        take_step(model, optimiser, loss, cosine_rate(config.learning_rate, it, config.iterations, warmup=500))
        running = loss.item() if running is None else 0.98 * running + 0.02 * loss.item()
        done = it + 1
        if done % config.validate_every == 0 or done == config.iterations:
            model.eval()
            with torch.no_grad():
                val_loss = ((predict(schedule.add_noise(val_batch, val_t, val_noise), val_t) - val_batch) ** 2).mean()
            if log:
                log(
                    {
                        "iteration": done,
                        "train_loss": running,
                        "val_loss": float(val_loss),
                        "seconds": time.time() - began,
                    }
                )
        if done % config.checkpoint_every == 0 or done == config.iterations:
            checkpoint(done)
    model.eval()
    return bundle
