"""An evaluation from files, as ``platypose eval`` and ``platypose calibrate-prior`` ask for one: known 3D motion
projected through cameras, lifted and scored (a table per set of unseen motion), or the prior's one-view temperature
fitted on its calibration clips and written into its checkpoint.

Files are read and written here (the motion, the calibration, the prior, the table as JSON, the checkpoint); the
lines a person reads are said through ``say``, and bad input is an InputError naming the option or file.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import write_text_atomic
from platypose.lifting.settings import PriorSettings, SamplerConfig


def floor_plane(text: str) -> tuple[float, float, float, float] | None:
    """The level floor ``--floor`` gives evaluation: auto is the motion's z = 0; InputError for a tilted plane."""
    from platypose.lifting.floor import CALIBRATED_FLOOR, parse_floor
    from platypose.lifting.offline.evaluation import floor_height

    floor = parse_floor(text)
    plane = CALIBRATED_FLOOR.plane if floor == "auto" else (None if floor is None else floor.plane)
    try:
        floor_height(plane)
    except ValueError as err:
        raise InputError(f"--{err}") from None
    return plane


@dataclass(frozen=True)
class EvalRun:
    """What one evaluation is asked for: the ``motion`` files or folders, or a file of unseen ``sets``; the
    calibration ``cams`` (None: a ring of 4 Human3.6M-like cameras), the first ``views`` of them (None: all); the
    window lengths ``frames`` and hypothesis counts ``samples`` of the table's rows, ``windows`` cut from each clip
    per length, ``noise_px`` added to the 2D; only the prior's ``heldout`` clips; the frame-by-frame ``baseline``;
    hypotheses made ``rigid``; a centred gap of ``gap_s`` seconds; the table also written as JSON to ``json_out``."""

    motion: tuple[Path, ...]
    sets: Path | None
    cams: Path | None
    views: int | None
    frames: tuple[int, ...]
    samples: tuple[int, ...]
    noise_px: float
    windows: int
    heldout: bool
    baseline: bool
    rigid: bool
    gap_s: float
    json_out: Path | None


def run_evaluation(run: EvalRun, prior: PriorSettings, config: SamplerConfig, say: Callable[[str], None]) -> None:
    """Lift and score ``run`` with ``prior`` and the sampler ``config``; ``say`` each set's header and rows."""
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.camera_rigs import ring_cameras
    from platypose.lifting.offline.evaluation import evaluate, floor_height, format_header
    from platypose.lifting.prior.runtime import load_settings
    from platypose.lifting.timebase import resample

    bundle = load_settings(prior)
    if max(run.frames) > bundle.config.max_frames:
        raise InputError(f"--frames: the prior handles at most {bundle.config.max_frames} frames")
    if run.cams is not None:
        from platypose.lifting.calibration import load_calibration

        cameras = list(load_calibration(run.cams).cameras)
    else:
        cameras = ring_cameras(4)
    if run.views is not None:
        if run.views > len(cameras):
            raise InputError(f"--views {run.views}: only {len(cameras)} cameras")
        cameras = cameras[: run.views]
    if bool(run.motion) == (run.sets is not None):
        raise InputError("eval: give MOTION (files or folders) or --sets (a file of unseen sets), not both")
    if run.sets is not None:
        from platypose.lifting.offline.unseen_sets import load_sets

        named = load_sets(run.sets)
    else:
        named = {"": list(run.motion)}
    plane = config.floor
    payload_sets = {}
    for name, paths in named.items():
        motions = load_motion_paths(paths)
        if run.heldout:
            from platypose.lifting.offline.calibration import calibration_clip_names

            names = {c["name"] for c in bundle.manifest.get("clips", []) if c.get("split") == "validation"}
            names -= set(calibration_clip_names(bundle.manifest)) if "temperature" in bundle.manifest else set()
            motions = [m for m in motions if m.name in names]
        clips = [resample(m.joints, m.fps, bundle.fps) for m in motions]
        clips = [c for c in clips if len(c) and not (c != c).any()]
        if not clips:
            where = f"set '{name}' of {run.sets}" if name else ", ".join(map(str, run.motion))
            raise InputError(f"{where}: no complete (full-body) clips to evaluate")
        longest = max(len(c) for c in clips)
        too_long = [f for f in run.frames if f > longest]
        if too_long:  # no window of that length: its rows would be missing from the table
            raise InputError(
                f"--frames {','.join(map(str, too_long))}: longer than every clip (the longest has {longest} frames "
                f"at the prior's {bundle.fps:g} fps)"
            )
        say(
            (f"set {name}: " if name else "")
            + f"{len(clips)} clips, prior {bundle.checksum[:12]}, {len(cameras)} cameras, noise {run.noise_px} px, "
            f"floor {'none' if plane is None else f'z = {floor_height(plane):g}'}, {os.cpu_count()} CPUs"
        )
        say(format_header())
        rows = evaluate(
            bundle,
            clips,
            cameras,
            list(run.frames),
            list(run.samples),
            config,
            run.windows,
            run.noise_px,
            run.baseline,
            progress=say,
            rigid=run.rigid,
            gap_s=run.gap_s,
        )
        payload_sets[name] = [r.as_dict() for r in rows]
    if run.json_out:
        payload = {
            "prior": bundle.checksum,
            "cameras": len(cameras),
            "noise_px": run.noise_px,
            "rigid": run.rigid,
            "gap_s": run.gap_s,
            "config": config.__dict__,
            **({"sets": payload_sets} if run.sets is not None else {"rows": payload_sets[""]}),
        }
        write_text_atomic(run.json_out, json.dumps(payload, indent=2))


def calibrate_temperatures(
    data: Sequence[Path],
    prior_path: Path | None,
    out: Path,
    *,
    frames: Sequence[int],
    windows: int,
    samples: int,
    temperatures: Sequence[float],
    seed: int,
    threads: int,
    say: Callable[[str], None],
) -> None:
    """Fit the prior's one-view temperature per window length (``frames``) on its calibration clips among ``data``
    (``windows`` per clip and length, ``samples`` hypotheses, each of ``temperatures`` tried) and write the prior
    with it into ``out``; ``say`` what it fits on, its progress and what it wrote."""
    from platypose.lifting.files.atomic import check_writable
    from platypose.lifting.floor import CALIBRATED_FLOOR
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.calibration import calibration_clip_names, fit_temperatures
    from platypose.lifting.offline.camera_rigs import ring_cameras
    from platypose.lifting.prior.model import load_prior, save_prior
    from platypose.lifting.prior.runtime import load_for_runtime
    from platypose.lifting.timebase import resample

    check_writable(out)
    bundle, extra = load_prior(prior_path)
    if max(frames) > bundle.config.max_frames:
        raise InputError(f"--frames: the prior handles at most {bundle.config.max_frames} frames")
    names = set(calibration_clip_names(bundle.manifest))
    motions = [m for m in load_motion_paths(data) if m.name in names]
    clips = [resample(m.joints, m.fps, bundle.fps) for m in motions]
    clips = [c for c in clips if len(c) and not (c != c).any()]
    if not clips:
        raise InputError(f"{', '.join(map(str, data))}: none of the prior's calibration clips is here")
    say(f"fitting on {len(clips)} of the prior's validation clips: {', '.join(m.name for m in motions)}")
    sampler = SamplerConfig(samples=samples, seed=seed, floor=CALIBRATED_FLOOR.plane)
    fitted = fit_temperatures(
        load_for_runtime(prior_path, "cpu", "auto", threads),
        clips,
        ring_cameras(4)[0],
        list(frames),
        sampler,
        windows,
        list(temperatures),
        progress=say,
    )
    fitted.update({"views": 1, "clips": sorted(names), "samples": samples, "windows": windows, "seed": seed})
    bundle.manifest["temperature"] = fitted
    checksum = save_prior(out, bundle, extra=extra or None)
    chosen = ", ".join(f"{f} frames {t:g}" for f, t in fitted["by_frames"].items())
    say(f"wrote {out} (sha256 {checksum[:12]}): temperature {chosen}")
