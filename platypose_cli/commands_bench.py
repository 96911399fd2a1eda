"""``platypose bench``: sampler speed, network utilisation against a matmul reference, and an end-to-end clip."""

from __future__ import annotations

import json
import os
import platform
import stat
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from platypose.cli.terminal.options import settings_options
from platypose.data import VIDEO_DIR

if TYPE_CHECKING:
    from platypose.lifting.settings import PriorSettings, SamplerConfig

DEMO_VIDEO = VIDEO_DIR / "sports2d-demo" / "demo.mp4"

SKIPPED_STEPS = 2  # as ``platypose lift``: --steps 10 --skip 2 runs 8 network calls
CLIP_FPS = 30.0
CLIP_HYPOTHESES = 50
MAX_CLIP_S = 600.0  # --clip-seconds: 18,000 frames looped into TMPDIR at most


def sampler_settings(prior, sampler, frames: int, steps: int, repeats: int, matmul_size: int):
    """``sampler`` running ``steps`` network calls (``steps + 2`` kept, 2 skipped, as ``platypose lift``);
    InputError for sizes the prior or the bench cannot run."""
    from dataclasses import replace

    from platypose.lifting.errors import InputError

    if not 1 <= frames <= prior.config.max_frames:
        raise InputError(f"--frames {frames}: the prior's windows hold 1..{prior.config.max_frames} frames")
    if not 1 <= steps <= prior.config.diffusion_steps - SKIPPED_STEPS:
        raise InputError(f"--steps must be in 1..{prior.config.diffusion_steps - SKIPPED_STEPS}, got {steps}")
    if repeats < 1 or matmul_size < 1:
        raise InputError(f"--repeats and --matmul-size must be positive, got {repeats} and {matmul_size}")
    try:
        return replace(sampler, steps=steps + SKIPPED_STEPS, skip=SKIPPED_STEPS)
    except ValueError as err:
        raise InputError(f"sampler: {err}") from None


def sampler_section(prior, config, frames: int, repeats: int, matmul_size: int, runtime: str) -> dict:
    """Time the sampler and the matmul reference; the ``sampler`` part of the report."""
    import statistics

    from platypose.lifting.offline.benchmark import matmul_probe, time_sampler

    probes = {name: matmul_probe(matmul_size, prior.device, name) for name in dict.fromkeys(("float32", runtime))}
    rates: dict[str, list[float]] = {name: [] for name in probes}
    for probe in probes.values():
        probe()  # warm-up

    def between() -> None:
        for name, probe in probes.items():
            rates[name].append(probe())

    timing = time_sampler(prior, config, frames, repeats, between=between)
    reference = statistics.median(rates["float32"])  # the machine's figure, whatever the network runs in
    own = statistics.median(rates[runtime])  # the kernels the network runs: what utilisation compares with
    return {
        "samples": config.samples,
        "frames": frames,
        "device": str(prior.device),
        "runtime": runtime,
        "steps": timing.calls,
        "guidance_iters": config.guidance_iters,
        "repeats": repeats,
        "run_s": timing.run_s,
        "hypothesis_frames_per_s": config.samples * frames / timing.run_s,
        "hypothesis_frames_per_matmul_gflop": config.samples * frames / timing.run_s / reference,
        "step_s": timing.step_s,
        "network_step_s": timing.network_step_s,
        "guidance_step_s": timing.guidance_step_s,
        "network_gflop_per_step": timing.flops_per_call / 1e9,
        "network_gflops": timing.network_gflops,
        "matmul_size": matmul_size,
        "matmul_gflops": reference,
        "runtime_matmul_gflops": own,
        "utilisation": timing.network_gflops / own,
    }


def check_video_to_loop(video: Path) -> None:
    """InputError naming ``video`` unless it is a regular file (a FIFO, a device or a folder is no video to loop)."""
    from platypose.lifting.errors import InputError
    from platypose.lifting.files.reads import file_kind

    try:
        mode = os.stat(video).st_mode
    except OSError:
        raise InputError(f"{video}: video to loop not found (give --video)") from None
    if not stat.S_ISREG(mode):
        raise InputError(f"{video}: is {file_kind(mode)}, not a video file to loop (give --video)")


def clip_section(prior, video: Path, seconds: float, threads: int | None, say, persons: str = "largest") -> dict:
    """Loop ``video`` into a ``seconds`` long 30 fps clip, detect it and lift the ``persons`` it selects (largest,
    all or a count); the ``end_to_end`` part of the report."""
    from platypose.cli.runs.bench_clip import lift_clip, loop_video

    frames = max(1, round(seconds * CLIP_FPS))
    with tempfile.TemporaryDirectory(prefix="platypose-bench-") as folder:
        clip = Path(folder) / "clip.mp4"
        say(f"writing a {frames}-frame clip looped from {video.name}")
        height, width = loop_video(video, clip, frames, CLIP_FPS)
        timing = lift_clip(clip, prior, CLIP_HYPOTHESES, threads, say, persons)
    return {
        "video": str(video),
        "seconds": frames / CLIP_FPS,
        "fps": CLIP_FPS,
        "frames": timing.frames,
        "image_size": [height, width],
        "tracks": timing.tracks,
        "persons": persons,
        "persons_lifted": timing.persons,
        "person_frames": timing.person_frames,
        "hypotheses": CLIP_HYPOTHESES,
        "detect_s": timing.detect_s,
        "lift_s": timing.lift_s,
        "total_s": timing.detect_s + timing.lift_s,
        "detect_cpu_s": timing.detect_cpu_s,
        "lift_cpu_s": timing.lift_cpu_s,
        "lift_cpu_s_per_person_minute": timing.lift_cpu_s / max(timing.person_frames / (60 * CLIP_FPS), 1e-9),
        "detect_peak_rss_mb": timing.detect_peak_rss_mb,
        "peak_rss_mb": timing.peak_rss_mb,
        "phases": {name: list(span) for name, span in timing.phases.items()},
    }


def end_to_end_section(prior, video: Path, seconds: float, threads: int | None, say, persons: str) -> dict:
    """:func:`clip_section` (run first: its peak memory is its own) with SIGTERM handled as Ctrl-C, so either removes
    the temporary clip on the way out (exit 130)."""
    from platypose.cli.runs.workers import terminate_as_interrupt

    try:
        with terminate_as_interrupt():
            return clip_section(prior, video, seconds, threads, say, persons)
    except KeyboardInterrupt:
        typer.echo("interrupted; the temporary clip was removed", err=True)
        raise typer.Exit(130) from None


def _row(label: str, value: str) -> str:
    """One indented table row: the label padded to a fixed column, then the value."""
    return f"  {label:<34s}{value:>10s}"


def report_lines(report: dict) -> list[str]:
    """The printed table of a bench report (the same numbers as the JSON)."""
    m, p, s = report["machine"], report["prior"], report["sampler"]
    lines = [
        (
            f"machine: {m['cpu']}, {m['cores']} cores, {m['threads']} torch thread(s), "
            f"load average {m['load_average'][0]:.2f} (1 min) {m['load_average'][1]:.2f} (5 min) at the end"
        ),
        f"prior: {p['path']} ({p['layers']} layers, width {p['width']}, {p['heads']} heads, FF {p['ff_width']})",
        (
            f"sampler: {s['samples']} hypotheses x {s['frames']} frames, {s['steps']} steps x "
            f"{s['guidance_iters']} guidance iterations, median of {s['repeats']} runs after a warm-up, "
            f"{s['runtime']} network on {s['device']}"
        ),
        _row("hypothesis-frames per second", f"{s['hypothesis_frames_per_s']:.1f}"),
        _row("  per matmul GFLOP/s", f"{s['hypothesis_frames_per_matmul_gflop']:.1f}"),
        _row("seconds per run", f"{s['run_s']:.3f}"),
        _row("seconds per diffusion step", f"{s['step_s']:.4f}"),
        _row("  network", f"{s['network_step_s']:.4f}"),
        _row("  guidance", f"{s['guidance_step_s']:.4f}"),
        _row("guidance share of sampling", f"{100 * s['guidance_step_s'] / s['step_s']:.1f} %"),
        _row("network GFLOP per step (analytic)", f"{s['network_gflop_per_step']:.3f}"),
        _row("network GFLOP/s", f"{s['network_gflops']:.2f}"),
        _row(f"matmul GFLOP/s ({s['matmul_size']}^2 float32)", f"{s['matmul_gflops']:.2f}"),
        *(
            [_row(f"matmul GFLOP/s ({s['matmul_size']}^2 {s['runtime']})", f"{s['runtime_matmul_gflops']:.2f}")]
            if s["runtime"] != "float32"
            else []
        ),
        _row(f"utilisation (vs {s['runtime']} matmul)", f"{100 * s['utilisation']:.1f} %"),
    ]
    e = report["end_to_end"]
    if e is not None:
        lines += [
            (
                f"end-to-end: {e['seconds']:g} s clip at {e['fps']:g} fps ({e['frames']} frames, "
                f"{e['image_size'][1]}x{e['image_size'][0]}), {e['tracks']} track(s), {e['persons_lifted']} lifted "
                f"(--persons {e['persons']}) with {e['hypotheses']} hypotheses where present"
            ),
            _row("person-frames present", f"{e['person_frames']}"),
            _row("detection seconds", f"{e['detect_s']:.1f}"),
            _row(f"lifting seconds ({e['persons_lifted']} person(s))", f"{e['lift_s']:.1f}"),
            _row("lifting CPU s per person-minute", f"{e['lift_cpu_s_per_person_minute']:.1f}"),
            _row("total seconds", f"{e['total_s']:.1f}"),
            _row("CPU seconds (detection + lifting)", f"{e['detect_cpu_s']:.0f} + {e['lift_cpu_s']:.0f}"),
            _row("peak RSS MiB after detection", f"{e['detect_peak_rss_mb']:.0f}"),
            _row("peak RSS MiB after lifting", f"{e['peak_rss_mb']:.0f}"),
            "  phases (seconds from the start to the end):",
            *(_row(f"  {name}", f"{start:.1f}-{end:.1f}") for name, (start, end) in e["phases"].items()),
        ]
    lines.append(f"peak RSS of the whole run: {report['peak_rss_mb']:.0f} MiB")
    if m["load_average"][0] > m["cores"]:
        lines.append("note: load average above the core count; other work shared the CPU, compare utilisation")
    return lines


@settings_options("prior", parameter="prior_settings")
@settings_options("sampler", exclude=("steps", "skip"), defaults={"samples": 200})  # --steps: network calls
def bench(
    *,
    frames: int = typer.Option(64, "--frames", help="Frames per window."),
    steps: int = typer.Option(8, "--steps", help="Diffusion steps run (network calls; 2 more are kept and skipped)."),
    repeats: int = typer.Option(3, "--repeats", help="Timed runs after one warm-up; the median run is reported."),
    matmul_size: int = typer.Option(2048, "--matmul-size", help="Side of the square float32 matmul reference."),
    threads: int | None = typer.Option(
        None, "--threads", min=1, help="torch and onnxruntime threads (default: 1, as lift)."
    ),
    end_to_end: bool = typer.Option(True, "--end-to-end/--no-end-to-end", help="Also detect and lift a looped clip."),
    clip_seconds: float = typer.Option(
        60.0, "--clip-seconds", help=f"Length of the end-to-end clip (30 fps; above 0, at most {MAX_CLIP_S:g})."
    ),
    video: Path = typer.Option(DEMO_VIDEO, "--video", help="Video looped into the end-to-end clip."),
    persons: str = typer.Option(
        "largest", "--persons", help="Tracks of the clip lifted: largest, all, or largest:N (the N largest; as lift)."
    ),
    json_path: Path | None = typer.Option(None, "--json", help="Also write the report as JSON here."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress lines."),
    prior_settings: PriorSettings = None,
    sampler: SamplerConfig = None,
) -> None:
    """Time the guided sampler and a whole single-view clip on this machine (docs/bench.md)."""
    import torch

    from platypose.cli.runs.bench_clip import peak_rss_mb
    from platypose.cli.runs.workers import threads_for
    from platypose.detectors.tracking.tracker import persons_count
    from platypose.lifting.errors import InputError
    from platypose.lifting.files.atomic import write_text_atomic
    from platypose.lifting.prior.model import DEFAULT_PRIOR
    from platypose.lifting.prior.runtime import load_settings, resolve_runtime

    def say(message: str) -> None:
        if not quiet:
            typer.echo(message, err=True)

    if end_to_end and not 0 < clip_seconds <= MAX_CLIP_S:  # NaN fails too
        raise InputError(f"--clip-seconds {clip_seconds:g}: give a length in seconds above 0, at most {MAX_CLIP_S:g}")
    if end_to_end:
        check_video_to_loop(video)
    persons_count(persons)  # InputError for a value --persons does not take
    threads = threads_for(threads)
    torch.set_num_threads(threads)
    prior = load_settings(prior_settings, threads)
    if end_to_end and prior.device.type != "cpu":
        raise InputError(
            f"--device {prior_settings.device}: the end-to-end clip is lifted on the CPU only (add --no-end-to-end)"
        )
    sampler = sampler_settings(prior, sampler, frames, steps, repeats, matmul_size)
    clip = end_to_end_section(prior, video, clip_seconds, threads, say, persons) if end_to_end else None
    say(f"timing the sampler: {sampler.samples} x {frames} frames, 1 warm-up and {repeats} runs")
    runtime = resolve_runtime(prior_settings.runtime, prior.device)  # what auto picked
    timed = sampler_section(prior, sampler, frames, repeats, matmul_size, runtime)
    config = prior.config
    report = {
        "machine": {
            "cpu": platform.processor() or platform.machine(),
            "cores": os.cpu_count(),
            "threads": torch.get_num_threads(),
            "load_average": list(os.getloadavg()),
            "torch": torch.__version__,
        },
        "prior": {
            "path": str(prior_settings.path or DEFAULT_PRIOR),
            "sha256": prior.checksum,
            "layers": config.layers,
            "width": config.width,
            "heads": config.heads,
            "ff_width": config.ff_width,
        },
        "sampler": timed,
        "end_to_end": clip,
        "peak_rss_mb": peak_rss_mb(),
    }
    for line in report_lines(report):
        typer.echo(line)
    if json_path is not None:
        write_text_atomic(json_path, json.dumps(report, indent=2) + "\n")
        say(f"wrote {json_path}")
