"""``platypose calib convert`` and ``platypose calib check``: import any calibration, inspect and verify it."""

from __future__ import annotations

from pathlib import Path

import typer

from platypose.cli.terminal.options import field_option
from platypose.lifting.settings import TakeSettings

calib_app = typer.Typer(help="Convert camera calibrations to calib.json and check them.", no_args_is_help=True)

WORLD_UP_HELP = "Up axis of the file's world (x, y, z, -x, -y, -z); default: what the file states or z."
UNITS_HELP = "Length unit of the file: m, cm, mm, or metres per unit (e.g. a 0.04 board square)."
SUBJECT_HELP = "Human3.6M subject whose extrinsics to use (e.g. S9) when the file holds several."


@calib_app.command("convert")
def convert(
    source: Path = typer.Argument(
        ...,
        help=(
            "Calibration (Pose2Sim/anipose/FreeMoCap/Caliscope .toml, Qualisys .qca.txt, .yml, intri/extri folder,"
            " Human3.6M .json, .txt, calib.json) or a video (FOV prior)."
        ),
    ),
    out: Path = typer.Option(..., "--out", "-o", help="Native calib.json to write."),
    world_up: str = typer.Option(None, "--world-up", help=WORLD_UP_HELP),
    units: str = typer.Option(None, "--units", help=UNITS_HELP),
    subject: str = typer.Option(None, "--subject", help=SUBJECT_HELP),
) -> None:
    """Read a calibration in any supported format and write the native calib.json (Z up, metres).

    Given a video instead, write a one-camera calibration from its size: field-of-view prior, level camera at the origin.
    """
    from platypose.detectors.sources.video import VIDEO_SUFFIXES, video_info
    from platypose.lifting.calibration import load_calibration, save_calibration
    from platypose.lifting.calibration.defaults import default_calibration
    from platypose.lifting.files.atomic import check_writable

    check_writable(out)
    if source.suffix.lower() in VIDEO_SUFFIXES:
        height, width = video_info(source).image_size
        calibration = default_calibration(source.stem, height, width, str(source))
    else:
        calibration = load_calibration(source, world_up=world_up, units=units, subject=subject)
    save_calibration(out, calibration)
    typer.echo(f"wrote {out}: {len(calibration.cameras)} camera(s) {', '.join(calibration.names)}")
    for note in calibration.meta["assumptions"] + calibration.meta["conversions"]:
        typer.echo(f"  {note}")


def _check_videos(calibration, videos: list[Path]) -> None:
    """Match videos to cameras and warn about size differences."""
    from platypose.detectors.sources.video import video_info
    from platypose.lifting.calibration.matching import match_views
    from platypose.lifting.calibration.report import size_mismatch

    by_name = {v.name: v for v in videos}
    for camera_name, video_name in match_views(calibration.names, list(by_name), allow_missing=True).items():
        info = video_info(by_name[video_name])
        warning = size_mismatch(calibration.camera(camera_name), info.image_size, video_name)
        typer.echo(warning if warning else f"{camera_name} <- {video_name}: size matches")


def _check_keypoints(calibration, folder: Path, fps: float | None, sync: str) -> None:
    """Triangulate multi-view 2D keypoints (on one clock as ``sync`` says) and print the median reprojection error."""
    from platypose.detectors.sources.openpose import read_openpose_folder
    from platypose.lifting.calibration.matching import gather_views, match_views
    from platypose.lifting.errors import InputError
    from platypose.lifting.sync.choice import synchronise
    from platypose.lifting.triangulation import (
        associate_single_person,
        median_reprojection_error,
        triangulate,
        view_median_errors,
    )

    views = {d.name: d for d in sorted(folder.iterdir()) if d.is_dir()} if folder.is_dir() else {}
    if not views:
        raise InputError(f"{folder}: expected one sub-folder of keypoints per camera")
    matched = match_views(calibration.names, list(views))
    cameras = [calibration.camera(name) for name in matched]
    tracks = [read_openpose_folder(views[matched[c.name]], fps=fps, image_size=c.size) for c in cameras]
    cameras = synchronise(
        sync, [t.keypoints for t in tracks], [t.frame_times for t in tracks], cameras, typer.echo, _warn
    ).cameras
    period = min(float(t.frame_times[1] - t.frame_times[0]) if t.num_frames > 1 else 1.0 for t in tracks)
    candidates = gather_views([t.keypoints for t in tracks], [t.frame_times for t in tracks], cameras, 0.5 * period)
    keypoints = associate_single_person(candidates, cameras)
    points = triangulate(keypoints[..., :2], keypoints[..., 2], cameras)
    typer.echo(f"triangulated {keypoints.shape[1]} frames from {len(cameras)} views (17 joints, one person)")
    for camera, error in zip(cameras, view_median_errors(points, keypoints, cameras)):
        typer.echo(f"  {camera.name}: median reprojection error {error:.1f} px")
    typer.echo(f"median reprojection error {median_reprojection_error(points, keypoints, cameras):.1f} px")


def _warn(message: str) -> None:
    typer.echo(f"warning: {message}")


@calib_app.command("check")
def check(
    *,
    calib: Path = typer.Argument(..., help="Calibration file in any supported format."),
    videos: list[Path] = typer.Argument(None, help="Videos, matched to cameras by name; their sizes are compared."),
    keypoints: Path = typer.Option(
        None, "--keypoints", help="Folder with one OpenPose JSON sub-folder per camera: report triangulation error."
    ),
    fps: float = typer.Option(None, "--fps", help="Frame rate of the keypoints when no video sits beside them."),
    sync: str = field_option(TakeSettings, "sync"),
    world_up: str = typer.Option(None, "--world-up", help=WORLD_UP_HELP),
    units: str = typer.Option(None, "--units", help=UNITS_HELP),
    subject: str = typer.Option(None, "--subject", help=SUBJECT_HELP),
) -> None:
    """Print each camera, warn about videos whose size differs, and measure triangulation error on keypoints."""
    from platypose.lifting.calibration import load_calibration
    from platypose.lifting.calibration.report import describe_camera

    calibration = load_calibration(calib, world_up=world_up, units=units, subject=subject)
    typer.echo(
        f"{calib}: {len(calibration.cameras)} camera(s), format {calibration.meta['format']}, world Z up, metres"
    )
    for camera in calibration.cameras:
        typer.echo(f"  {describe_camera(camera)}")
    for note in calibration.meta["assumptions"] + calibration.meta["conversions"]:
        typer.echo(f"  note: {note}")
    if videos:
        _check_videos(calibration, videos)
    if keypoints is not None:
        _check_keypoints(calibration, keypoints, fps, sync)


@calib_app.command("estimate")
def estimate(
    videos: list[Path] = typer.Argument(..., help="Videos, one camera each (each in its own estimated world)."),
    out: Path = typer.Option(..., "--out", "-o", help="Calibration to write: .toml (Pose2Sim layout) or .json."),
    persons: str = field_option(TakeSettings, "persons"),
) -> None:
    """Estimate each video's camera as ``lift`` does without ``--cams`` and write it for ``--cams``.

    Roll and pitch from the scene's lines, the focal length from the video's metadata, the lines or the lens prior,
    the height above the floor from the people (docs/calibration.md). Each camera stands in its own estimated world
    (z = 0 its floor, the camera on the z axis looking along +y): one file for several videos names their cameras,
    it does not place them in one rig.
    """
    import torch

    from platypose.api import lift
    from platypose.cli.runs.workers import threads_for
    from platypose.lifting.calibration import save_calibration
    from platypose.lifting.calibration.model import Calibration, new_meta
    from platypose.lifting.calibration.toml_format import write_toml
    from platypose.lifting.errors import InputError
    from platypose.lifting.files.atomic import check_writable
    from platypose.lifting.tracks.quick_floor import FLOOR_PASS_SAMPLES

    if out.suffix.lower() not in (".toml", ".json"):
        raise InputError(f"{out}: --out must end in .toml (Pose2Sim layout) or .json (native)", option="out")
    check_writable(out)
    threads = threads_for(None)  # as lift's, so that its detections and quick lift are lift's
    torch.set_num_threads(threads)
    cameras, comments = [], [f"platypose calib estimate: {len(videos)} camera(s), each in its own estimated world"]
    for video in videos:
        result = lift(video, persons=persons, samples=FLOOR_PASS_SAMPLES, threads=threads)
        if "camera" not in result.meta or result.meta["floor"] is None:
            raise InputError(f"{video}: camera not estimated ({'; '.join(result.meta['notes'])})")
        cameras.append(result.cameras[0])
        said = [n for n in result.meta["notes"] if n.startswith("no cams:")] + [result.meta["floor"].get("frame", "")]
        comments += [f"{result.cameras[0].name}: {line}" for line in said if line]
    if out.suffix.lower() == ".toml":
        write_toml(out, cameras, comments)
    else:
        meta = new_meta("estimated", ", ".join(map(str, videos)), "z", "m")
        meta["assumptions"] = comments[1:]
        save_calibration(out, Calibration(cameras=tuple(cameras), meta=meta))
    typer.echo(f"wrote {out}: {len(cameras)} camera(s) {', '.join(c.name for c in cameras)}")
    for line in comments[1:]:
        typer.echo(f"  {line}")
