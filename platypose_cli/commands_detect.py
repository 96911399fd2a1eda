"""``platypose detect``: 2D keypoints of every person, tracked, written as our npz and CSV for inspection."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import typer

from platypose_cli.app import app

KEYPOINT_SUFFIXES = (".json", ".npz", ".csv")


def _image_size(value: str | None) -> tuple[int, int] | None:
    """``HEIGHTxWIDTH`` -> (height, width)."""
    from lifting.errors import InputError

    if value is None:
        return None
    height, sep, width = value.lower().partition("x")
    if not sep or not height.isdigit() or not width.isdigit():
        raise InputError(f"--image-size {value}: give HEIGHTxWIDTH in pixels, e.g. 1080x1920")
    return int(height), int(width)


def _summary(tracks, seconds: float, frames_run: int | None) -> list[str]:
    """Lines describing the tracks and the detection speed."""
    import numpy as np

    seen = (tracks.keypoints[..., 2] > 0).any(axis=2)
    lines = [
        f"{tracks.source}: {tracks.num_frames} frames, {tracks.num_persons} person track(s), "
        f"image {tracks.image_size[1]}x{tracks.image_size[0]} px"
    ]
    if frames_run == 0:
        lines.append("  detections read from the cache of an earlier run (--no-cache to detect again)")
    elif frames_run:
        per_frame = 1000 * seconds / frames_run
        lines.append(f"  decode + detect + track: {frames_run} frames in {seconds:.1f} s ({per_frame:.1f} ms/frame)")
    for p, track_id in enumerate(tracks.track_ids.tolist()):
        frames = np.nonzero(seen[:, p])[0]
        confidence = tracks.keypoints[seen[:, p], p, :, 2]
        lines.append(
            f"  track {track_id}: seen in {len(frames)}/{tracks.num_frames} frames "
            f"({tracks.frame_times[frames[0]]:.2f}-{tracks.frame_times[frames[-1]]:.2f} s), "
            f"mean joint confidence {confidence.mean():.2f}"
        )
    return lines


@app.command("detect")
def detect(
    source: Path = typer.Argument(
        ..., help="A video, or precomputed keypoints (OpenPose JSON folder, MMPose/minimal .json, our .npz/.csv)."
    ),
    out: Path = typer.Option(Path("out"), "--out", help="Output folder; files go to OUT/<name>/."),
    detector: Path | None = typer.Option(
        None, "--detector", help="Pose model .onnx (default: the bundled MoveNet MultiPose)."
    ),
    detector_format: str | None = typer.Option(
        None,
        "--detector-format",
        help="Model contract: movenet, yolo-pose, rtmo, rtmpose, heatmap (default: recognised).",
    ),
    person_detector: Path | None = typer.Option(
        None, "--person-detector", help="Person detector .onnx for top-down models (rtmpose, heatmap)."
    ),
    movenet_size: int = typer.Option(
        384, "--movenet-size", help="MoveNet input: longer side in pixels (multiple of 32)."
    ),
    threads: int | None = typer.Option(None, "--threads", help="onnxruntime intra-op threads (default: all cores)."),
    provider: str = typer.Option("CPUExecutionProvider", "--provider", help="onnxruntime execution provider."),
    persons: str = typer.Option("all", "--persons", help="Who to keep: all, largest, or N (the N largest)."),
    stride: int = typer.Option(1, "--stride", min=1, help="Detect every N-th frame."),
    max_frames: int | None = typer.Option(None, "--max-frames", min=1, help="Stop after this many processed frames."),
    fps: float | None = typer.Option(
        None, "--fps", help="Frame rate of precomputed keypoints (default: from the video beside them)."
    ),
    image_size: str | None = typer.Option(
        None, "--image-size", help="HEIGHTxWIDTH of precomputed keypoints (default: from the video)."
    ),
    cache: bool = typer.Option(
        True, "--cache/--no-cache", help="Reuse detections cached in OUT/<name>/ from an earlier run."
    ),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar."),
) -> None:
    """Detect and track people; write OUT/<name>/<name>_keypoints2d.npz and .csv (see docs/keypoints.md)."""
    from detectors.keypoint_files import write_keypoints_csv, write_keypoints_npz
    from detectors.tracking import persons_count, select_persons

    persons_count(persons)  # a bad --persons fails before any detection
    name = (source.name if source.is_dir() else source.stem).removesuffix("_json")
    folder = out / name
    started = time.perf_counter()
    frames_run = None
    if source.is_dir() or source.suffix.lower() in KEYPOINT_SUFFIXES:
        from detectors.sources import read_keypoints

        tracks = read_keypoints(source, fps=fps, image_size=_image_size(image_size))
    else:
        from detectors.contracts import load_detector
        from detectors.pipeline import detect_video
        from detectors.video import video_info

        info = video_info(source)
        model = load_detector(detector, detector_format, person_detector, threads, provider, movenet_size)
        total = -(-info.frame_count // stride)
        total = min(total, max_frames) if max_frames else total
        started = time.perf_counter()
        with typer.progressbar(
            length=max(total, 1), label=f"detecting {source.name}", file=sys.stderr, hidden=quiet
        ) as bar:
            done = [0]

            def progress(count: int, _total: int) -> None:
                bar.update(count - done[0])
                done[0] = count

            tracks = detect_video(
                source,
                model,
                stride=stride,
                max_frames=max_frames,
                progress=progress,
                cache_dir=folder if cache else None,
            )
        frames_run = done[0]
    seconds = time.perf_counter() - started
    tracks = select_persons(tracks, persons)
    written = [
        write_keypoints_npz(tracks, folder / f"{name}_keypoints2d.npz"),
        write_keypoints_csv(tracks, folder / f"{name}_keypoints2d.csv"),
    ]
    typer.echo("\n".join(_summary(tracks, seconds, frames_run)))
    for path in written:
        typer.echo(f"  wrote {path}")
