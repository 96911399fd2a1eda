"""Calibrating a prior's one-view spread: a temperature per window length, fitted on held-out clips.

The sampler's initial noise is scaled by a temperature (docs/prior.md#temperature). For each window length this
module lifts windows of held-out clips through one camera at every temperature of a grid and keeps the one whose
pooled ECE (as ``platypose eval`` computes it) is smallest; ties go to the temperature nearest 1. The clips are
half of the prior's validation split (every other one, :func:`calibration_clip_names`), which ``eval --heldout``
then leaves out, so the fit never sees what is evaluated. The result goes into the checkpoint's manifest
(``temperature``), and the sampler applies it to one-view lifts (:meth:`PriorBundle.temperature_for`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.offline import metrics
from platypose.lifting.offline.evaluation import cut_windows, floor_height, lift_windows, look_target, place_window
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.settings import SamplerConfig

DEFAULT_GRID = (0.7, 0.8, 0.9, 1.0, 1.1, 1.25, 1.4)


def calibration_clip_names(manifest: dict) -> list[str]:
    """The clips a calibration fits on: every other clip of the manifest's validation split, in manifest order."""
    return [c["name"] for c in manifest.get("clips", []) if c.get("split") == "validation"][::2]


def pooled_ece(hypotheses: np.ndarray, truth: np.ndarray) -> float:
    """ECE of windows ``(B, N, F, 17, 3)`` against ``(B, F, 17, 3)``, frequencies pooled over all windows."""
    frequencies = np.stack([metrics.calibration_frequencies(h, t) for h, t in zip(hypotheses, truth)])
    return metrics.ece_from_frequencies(frequencies.mean(axis=0))


def fit_temperatures(
    prior: PriorBundle,
    clips: Sequence[np.ndarray],
    camera: Camera,
    frames_list: Sequence[int],
    config: SamplerConfig,
    windows_per_clip: int,
    grid: Sequence[float] = DEFAULT_GRID,
    progress: Callable[[str], None] | None = None,
) -> dict:
    """Per window length, the grid temperature of smallest pooled ECE on ``clips`` ``(T, 17, 3)`` seen by one
    ``camera``, and every ECE measured: ``{"by_frames": {"16": 0.9, ...}, "ece": {"16": {"0.9": 0.05, ...}}}``.

    The prior's own calibration (if any) is set aside while fitting: the grid is the temperature itself.
    """
    plain = replace(prior, manifest={k: v for k, v in prior.manifest.items() if k != "temperature"})
    target, height = look_target([camera]), floor_height(config.floor)
    chosen, measured = {}, {}
    for frames in frames_list:
        windows, _ = cut_windows(clips, frames, windows_per_clip)
        if not windows:
            raise ValueError(f"no calibration clip has {frames} frames")
        truth = np.stack([place_window(w, target, height) for w in windows])
        eces = {}
        for temperature in grid:
            hyps = lift_windows(plain, [camera], truth, replace(config, temperature=temperature), 0.0, False)
            eces[temperature] = pooled_ece(hyps, truth)
            if progress:
                progress(
                    f"{frames} frames, {len(windows)} windows, temperature {temperature:g}: ECE {eces[temperature]:.3f}"
                )
        best = min(grid, key=lambda t: (round(eces[t], 4), abs(np.log(t))))
        chosen[str(frames)] = float(best)
        measured[str(frames)] = {f"{t:g}": round(e, 4) for t, e in eces.items()}
    return {"by_frames": chosen, "ece": measured}
