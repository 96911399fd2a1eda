"""``platypose eval``: lift known 3D motion projected through cameras and print the paper's metrics."""

from __future__ import annotations

import json
import os
from pathlib import Path

import typer

from platypose.cli.app import app
from platypose.cli.options import int_list, sampler_config
from platypose.lifting.atomic import write_text_atomic
from platypose.lifting.errors import InputError


@app.command("eval")
def evaluate_command(
    motion: list[Path] = typer.Argument(..., help="3D motion files or folders to project and lift."),
    cams: Path = typer.Option(None, "--cams", help="Calibration file; default: a ring of 4 Human3.6M-like cameras."),
    views: int = typer.Option(0, help="Use only the first this many cameras (0: all)."),
    frames: str = typer.Option("1,16,64", help="Window lengths to evaluate, comma-separated."),
    samples: str = typer.Option("50,200", help="Numbers of hypotheses, comma-separated."),
    noise_px: float = typer.Option(0.0, help="Gaussian noise (px, std) added to the projected 2D keypoints."),
    windows: int = typer.Option(2, help="Windows cut from each clip per window length."),
    heldout: bool = typer.Option(False, "--heldout", help="Only clips the prior held out of training (its manifest)."),
    baseline: bool = typer.Option(True, help="Also run the frame-by-frame baseline."),
    prior: Path = typer.Option(None, help="Prior checkpoint (default: the shipped one)."),
    steps: int = typer.Option(10, help="Respaced diffusion steps T."),
    skip: int = typer.Option(2, help="Skipped steps S."),
    eta: float = typer.Option(0.0, help="DDIM eta: 0 deterministic re-noising, 1 fresh noise (more diversity)."),
    guidance_iters: int = typer.Option(10, "--k", help="Guidance steps per diffusion step."),
    energy_scale: float = typer.Option(1.0, "--lambda", help="Guidance scale."),
    robust: str = typer.Option("l2", help="Reprojection loss: l2 or geman-mcclure."),
    size_prior: bool = typer.Option(True, help="Place each prediction as a person of median adult size."),
    size_spread: float = typer.Option(
        0.1, help="Log-normal spread of the hypotheses' sizes about adult size (0: all typical)."
    ),
    noise_fit: bool = typer.Option(True, help="Follow the 2D only as far as its measured jitter allows."),
    noise_spread: bool = typer.Option(True, help="2+ views: spread hypotheses by the 2D noise."),
    bone_weight: float = typer.Option(0.0, help="Weight of the constant-bone-length energy (0: off)."),
    symmetry_weight: float = typer.Option(0.0, help="Weight of the left/right symmetry energy (0: off)."),
    depth_smoothness: float = typer.Option(10.0, help="One view: smoothness of every joint's depth path (0: off)."),
    seed: int = typer.Option(0, help="Random seed."),
    json_out: Path = typer.Option(None, "--json", help="Also write the table as JSON here."),
    device: str = typer.Option("cpu", help="cpu, cuda or auto (cuda when available)."),
    runtime: str = typer.Option("float32", help="Denoiser runtime: float32, bfloat16 or onnx (CPU; docs/bench.md)."),
) -> None:
    """Project motion through cameras, lift it, and print minMPJPE, minMPSPE, PA-*, MPJVE, ECE."""
    from platypose.lifting.camera_rigs import ring_cameras
    from platypose.lifting.evaluation import evaluate, format_header
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.runtime import load_for_runtime
    from platypose.lifting.timebase import resample

    frames_list = int_list(frames, "--frames")
    samples_list = int_list(samples, "--samples")
    config = sampler_config(
        steps=steps,
        skip=skip,
        eta=eta,
        guidance_iters=guidance_iters,
        energy_scale=energy_scale,
        robust=robust,
        bone_weight=bone_weight,
        symmetry_weight=symmetry_weight,
        size_prior=size_prior,
        size_spread=size_spread,
        noise_fit=noise_fit,
        noise_spread=noise_spread,
        depth_smoothness=depth_smoothness,
        seed=seed,
    )
    bundle = load_for_runtime(prior, device, runtime)
    if max(frames_list) > bundle.config.max_frames:
        raise InputError(f"--frames: the prior handles at most {bundle.config.max_frames} frames")
    if cams is not None:
        from platypose.lifting.calibration import load_calibration

        cameras = list(load_calibration(cams).cameras)
    else:
        cameras = ring_cameras(4)
    if views:
        if views > len(cameras):
            raise InputError(f"--views {views}: only {len(cameras)} cameras")
        cameras = cameras[:views]
    motions = load_motion_paths(motion)
    if heldout:
        names = {c["name"] for c in bundle.manifest.get("clips", []) if c.get("split") == "validation"}
        motions = [m for m in motions if m.name in names]
    clips = [resample(m.joints, m.fps, bundle.fps) for m in motions]
    clips = [c for c in clips if len(c) and not (c != c).any()]
    if not clips:
        raise InputError(f"{', '.join(map(str, motion))}: no complete (full-body) clips to evaluate")
    typer.echo(
        f"{len(clips)} clips, prior {bundle.checksum[:12]}, {len(cameras)} cameras, noise {noise_px} px, "
        f"{os.cpu_count()} CPUs"
    )
    typer.echo(format_header())
    rows = evaluate(
        bundle, clips, cameras, frames_list, samples_list, config, windows, noise_px, baseline, progress=typer.echo
    )
    if json_out:
        payload = {
            "prior": bundle.checksum,
            "cameras": len(cameras),
            "noise_px": noise_px,
            "config": config.__dict__,
            "rows": [r.as_dict() for r in rows],
        }
        write_text_atomic(json_out, json.dumps(payload, indent=2))
