"""``platypose detect``: 2D keypoints of every person, tracked, written as our npz and CSV for inspection."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from platypose.cli.runs.models import command_reader
from platypose.cli.terminal.options import settings_options

if TYPE_CHECKING:
    from platypose.lifting.settings import DetectOptions


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
        if len(frames) == 0:
            lines.append(f"  person {track_id}: not seen in this view")
            continue
        confidence = tracks.keypoints[seen[:, p], p, :, 2]
        lines.append(
            f"  person {track_id}: seen in {len(frames)}/{tracks.num_frames} frames "
            f"({tracks.frame_times[frames[0]]:.2f}-{tracks.frame_times[frames[-1]]:.2f} s), "
            f"mean joint confidence {confidence.mean():.2f}"
        )
    return lines


def _comparison(tracks, reference_path: Path, fps: float | None, image_size: tuple[int, int] | None) -> list[str]:
    """Lines with the per-joint median pixel distance from the reference's main person to the nearest track."""
    import numpy as np

    from platypose.detectors.sources.keypoint_source import read_keypoints
    from platypose.detectors.tracking.compare import distances_to_reference
    from platypose.detectors.tracking.tracker import persons_to_keep
    from platypose.lifting.skeleton import JOINT_NAMES

    reference = read_keypoints(reference_path, fps=fps, image_size=image_size)
    main = int(persons_to_keep([reference], "largest")[0])
    distances = distances_to_reference(tracks, reference, main)
    found = np.isfinite(distances).any(axis=1)
    if not found.any():
        return [f"  compared with {reference_path}: no frame where both have the person"]
    per_joint = ", ".join(f"{name} {np.nanmedian(distances[:, j]):.1f}" for j, name in enumerate(JOINT_NAMES))
    return [
        f"  compared with {reference_path} (person {reference.track_ids[main]}, {found.sum()}/{len(found)} frames): "
        f"median {np.nanmedian(distances):.1f} px, 90th percentile {np.nanpercentile(distances, 90):.1f} px",
        f"  per joint (median px): {per_joint}",
    ]


@settings_options("detect", parameter="options", panel=None, in_place=True)
def detect(
    sources: list[Path] = typer.Argument(
        ...,
        help="Videos, or precomputed keypoints (OpenPose JSON folder, MMPose/minimal .json, our .npz/.csv); "
        "several views of one scene with --cams.",
    ),
    out: Path = typer.Option(Path("out"), "--out", help="Output folder; files go to OUT/<name>/."),
    cams: Path | None = typer.Option(
        None, "--cams", help="Calibration: the sources are synchronised views, people get one ID across views."
    ),
    options: DetectOptions = None,
    persons: str = typer.Option(
        "all", "--persons", help="Who to keep: all, largest, largest:N (the N largest), ids id:0,2, or @X,Y."
    ),
    compare: Path | None = typer.Option(
        None,
        "--compare",
        help="Reference keypoints of the same (single) video: print per-joint pixel distances of its main person.",
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
) -> None:
    """Detect and track people; write OUT/<name>/<name>_keypoints2d.npz and .csv per source (docs/keypoints.md)."""
    from platypose.cli.terminal.safe_names import safe_name
    from platypose.detectors.sources.keypoint_files import write_keypoints_csv, write_keypoints_npz
    from platypose.detectors.sources.keypoint_source import view_name
    from platypose.detectors.tracking.tracker import persons_count, persons_to_keep
    from platypose.lifting.files.atomic import check_writable

    persons_count(persons)  # a bad --persons fails before any detection
    names = [safe_name(view_name(source)) for source in sources]
    for name in names:
        check_writable(out / name, folder=True)
    cameras = None
    if cams is not None:
        from platypose.lifting.calibration import load_calibration
        from platypose.lifting.calibration.matching import match_views

        calibration = load_calibration(cams)
        pairs = match_views(calibration.names, names, allow_missing=True)
        by_view = {view: calibration.camera(camera) for camera, view in pairs.items()}
        cameras = [by_view[name] for name in names]
    elif len(set(names)) != len(names):
        from platypose.lifting.errors import InputError

        raise InputError(f"two sources share the output name {names}; give them different names")
    folders = {source: out / name for source, name in zip(sources, names)}
    read = command_reader(options, folders.__getitem__, quiet)
    results = [read(source) for source in sources]
    views = [r.tracks for r in results]
    if cameras is not None:
        from platypose.detectors.persons.multiview import match_across_views

        views = match_across_views(views, cameras)
    comparison = []
    if compare is not None:
        if len(views) != 1:
            from platypose.lifting.errors import InputError

            raise InputError(f"--compare {compare}: compare one source at a time")
        comparison = _comparison(views[0], compare, options.fps, options.image_size)
    keep = persons_to_keep(views, persons)
    for name, tracks, result in zip(names, views, results):
        tracks = tracks if keep is None else tracks.select(keep)
        written = [
            write_keypoints_npz(tracks, out / name / f"{name}_keypoints2d.npz"),
            write_keypoints_csv(tracks, out / name / f"{name}_keypoints2d.csv"),
        ]
        typer.echo("\n".join(_summary(tracks, result.seconds, result.frames)))
        for note in tracks.notes:
            typer.echo(f"warning: {note}", err=True)
        for path in written:
            typer.echo(f"  wrote {path}")
    if comparison:
        typer.echo("\n".join(comparison))
