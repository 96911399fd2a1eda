"""The settings of training a prior: its architecture, the optimisation and augmentation, distillation."""

from __future__ import annotations

from dataclasses import dataclass

from platypose.lifting.settings.fields import at_least_one, check_types, require, setting


@dataclass(frozen=True)
class PriorArchitecture:
    """The prior network's size and frame rate, as ``train`` builds it (``train`` has each field as an option);
    :class:`~platypose.lifting.prior.model.PriorConfig` adds the sizes fixed by the schedule and the features, and
    checks them all."""

    layers: int = setting(4, "Transformer layers.", option=True)
    width: int = setting(256, "Token width.", option=True)
    heads: int = setting(4, "Attention heads.", option=True)
    ff_width: int = setting(512, "Feed-forward width.", option=True)
    dropout: float = setting(0.1, "Dropout of the attention and feed-forward layers while training.")
    max_frames: int = setting(64, "Longest window the prior handles.", option=True)
    fps: float = setting(30.0, "Frame rate the prior runs at; clips are resampled to it.", option=True)


@dataclass(frozen=True)
class TrainConfig:
    """Optimisation and augmentation settings of training a prior."""

    iterations: int = setting(20000, "Optimiser steps.", option=True)
    batch_size: int = setting(64, "Windows per step.", option=True)
    learning_rate: float = setting(3e-4, "Peak learning rate (cosine decay).", option=True)
    weight_decay: float = setting(1e-4, "AdamW weight decay.")
    validation_fraction: float = setting(0.15, "Share of the clips held out for validation.")
    time_scale: tuple[float, float] = setting((0.8, 1.25), "Range of the playback speed augmentation.")
    bone_scale: float = setting(0.15, "Per-bone length augmentation (+-).", option=True)
    global_scale: float = setting(0.10, "Whole-body size augmentation (+-).")
    mirror_probability: float = setting(0.5, "Probability of a left/right mirrored window.")
    checkpoint_every: int = setting(1000, "Write the checkpoint every this many steps.", option=True)
    validate_every: int = setting(250, "Validate (and log) every this many steps.", option=True)
    seed: int = setting(0, "Random seed.", option=True)

    def __post_init__(self) -> None:
        check_types(self)
        require(
            [
                *at_least_one(self, ("iterations", "batch_size", "checkpoint_every", "validate_every")),
                (
                    0 < self.learning_rate < 1,
                    "learning_rate",
                    f"learning_rate must be in (0, 1), got {self.learning_rate}",
                ),
                (self.weight_decay >= 0, "weight_decay", f"weight_decay must be >= 0, got {self.weight_decay}"),
                (0 <= self.bone_scale < 1, "bone_scale", f"bone_scale must be in [0, 1), got {self.bone_scale}"),
                (
                    0 <= self.global_scale < 1,
                    "global_scale",
                    f"global_scale must be in [0, 1), got {self.global_scale}",
                ),
                (0 <= self.validation_fraction < 1, "validation_fraction", "validation_fraction must be in [0, 1)"),
                (0 < self.time_scale[0] <= self.time_scale[1], "time_scale", "time_scale must be positive and ordered"),
                (0 <= self.mirror_probability <= 1, "mirror_probability", "mirror_probability must be in [0, 1]"),
                (0 <= self.seed < 2**63, "seed", f"seed must be in [0, 2**63), got {self.seed}"),
            ]
        )


@dataclass(frozen=True)
class DistilConfig:
    """Settings of one halving: the ``calls`` the student makes (half the teacher's), optimisation, checkpoints.

    ``start_share`` is the share of first-call rows drawn as the sampler starts them (the noise alone, no
    signal), the rest are noised training windows like every other call's.
    """

    calls: int = setting(4, "With --distil-from: the student's network calls (half the teacher's).", option=True)
    iterations: int = setting(4000, "Optimiser steps.")
    batch_size: int = setting(64, "Windows per step.")
    learning_rate: float = setting(1e-4, "Peak learning rate (cosine decay).")
    start_share: float = setting(0.5, "Share of first-call rows started from noise alone.")
    checkpoint_every: int = setting(250, "Write the checkpoint every this many steps.")
    validate_every: int = setting(250, "Validate every this many steps.")
    seed: int = setting(0, "Random seed.")

    def __post_init__(self) -> None:
        check_types(self)
        require(
            [
                *at_least_one(self, ("calls", "iterations", "batch_size", "checkpoint_every", "validate_every")),
                (
                    0 < self.learning_rate < 1,
                    "learning_rate",
                    f"learning_rate must be in (0, 1), got {self.learning_rate}",
                ),
                (0 <= self.start_share <= 1, "start_share", f"start_share must be in [0, 1], got {self.start_share}"),
                (0 <= self.seed < 2**63, "seed", f"seed must be in [0, 2**63), got {self.seed}"),
            ]
        )
