"""A 3D motion clip on our skeleton: the unit every importer returns and training consumes."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from platypose.lifting.skeleton import NUM_JOINTS


@dataclass(frozen=True)
class Motion:
    """Joint positions ``joints`` (T, 17, 3) in metres, world Z up, sampled at ``fps`` frames per second.

    ``name`` identifies the clip (usually the file name), ``source`` where it came
    from and ``licence`` its licence (SPDX-like id or a short text), both as
    recorded in a training checkpoint's data manifest.
    """

    joints: np.ndarray
    fps: float
    name: str
    source: str = ""
    licence: str = "unknown"
    extra: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        joints = np.asarray(self.joints, dtype=np.float64)
        if joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3):
            raise ValueError(f"{self.name}: motion must be (T, {NUM_JOINTS}, 3), got {joints.shape}")
        if not self.fps > 0:
            raise ValueError(f"{self.name}: frame rate must be positive, got {self.fps}")
        object.__setattr__(self, "joints", joints)

    @property
    def num_frames(self) -> int:
        """Number of frames."""
        return self.joints.shape[0]

    @property
    def duration_s(self) -> float:
        """Duration in seconds."""
        return self.num_frames / self.fps
