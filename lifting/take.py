"""One take on one clock, the value the take path hands down: :func:`platypose.pipeline.lift_take`, the floor's quick
lift (:func:`platypose.lifting.tracks.quick_floor.quick_floor`), :func:`platypose.lifting.tracks.persons.lift_persons`
and finishing (:func:`platypose.lifting.finish.steps.finish_take`) all take a :class:`Take`."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.tracks.roots import presence


@dataclass(frozen=True)
class Take:
    """The 2D ``keypoints`` ``(C, T, P, 17, 3)`` of persons ``track_ids`` ``(P,)`` seen by ``cameras`` (C) on one
    clock ``times`` ``(T,)``, each person's root path known (``roots[p]`` ``(T, 3)``) or None (solved per
    hypothesis), where each person is ``absent`` ``(P, T)`` (unseen for longer than ``windows.max_gap``: computed
    once, by :meth:`on_clock`), and how they are lifted: the ``sampler``'s settings and the ``windows``'."""

    keypoints: np.ndarray
    times: np.ndarray
    track_ids: np.ndarray
    cameras: tuple[Camera, ...]
    roots: tuple[np.ndarray | None, ...]
    absent: np.ndarray
    sampler: SamplerConfig
    windows: WindowSettings

    @classmethod
    def on_clock(
        cls,
        keypoints: np.ndarray,
        times: np.ndarray,
        track_ids: np.ndarray,
        cameras: Sequence[Camera],
        roots: Sequence[np.ndarray | None],
        *,
        sampler: SamplerConfig,
        windows: WindowSettings,
    ) -> Take:
        """The take of these arrays, each person's absence from :func:`platypose.lifting.tracks.roots.presence`
        under ``windows.max_gap`` (unseen up to it is lifted through)."""
        absent = ~presence(keypoints, times, windows.max_gap)
        return cls(keypoints, times, track_ids, tuple(cameras), tuple(roots), absent, sampler, windows)

    def frame_rate(self, alone: float) -> float:
        """Frames per second of the clock (its median step); ``alone`` for a take of one frame."""
        return 1.0 / float(np.median(np.diff(self.times))) if len(self.times) > 1 else alone

    def persons(self, chosen: Sequence[int]) -> Take:
        """The take of the persons ``chosen`` (indices along P) alone."""
        chosen = list(chosen)
        return Take(
            self.keypoints[:, :, chosen],
            self.times,
            self.track_ids[chosen],
            self.cameras,
            tuple(self.roots[p] for p in chosen),
            self.absent[chosen],
            self.sampler,
            self.windows,
        )
