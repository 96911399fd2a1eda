"""The settings of a batch of lift jobs: everything a job needs besides its views."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from platypose.lifting.settings import DetectOptions, PriorSettings, TakeSettings


@dataclass(frozen=True)
class RunSettings:
    """Everything a job needs besides its views (picklable, for worker processes)."""

    out: Path
    cams: Path | None = None
    prior: PriorSettings = field(default_factory=PriorSettings)
    detect: DetectOptions = field(default_factory=DetectOptions)
    take: TakeSettings = field(default_factory=TakeSettings)
    formats: tuple[str, ...] = ("npz", "csv", "bvh", "rrd")
    quiet: bool = False
    arguments: dict = field(default_factory=dict)
    split_seconds: float | None = None  # --split-seconds: one input spread over pieces (platypose.cli.runs.split)
