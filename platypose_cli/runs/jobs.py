"""What ``platypose lift`` has to do: INPUT paths, folders and globs -> jobs, each one take of one or more views.

A job is one output folder ``OUT/<name>/``. Loose videos (given on the command
line, matched by a glob, or lying in a folder) are the views of one take when a
calibration with several cameras is given and every video matches a camera by
name; otherwise each video is a job of its own. Each sub-folder of an INPUT
folder that holds videos is one take. ``--keypoints`` gives precomputed 2D for
one take: a file or OpenPose folder for one view, or a folder whose sub-folders
(or files) are matched to the cameras by name (Pose2Sim: ``cam01_json`` for
camera ``cam_01``).
"""

from __future__ import annotations

import glob
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from platypose.cli.terminal.safe_names import distinct_names, safe_name
from platypose.detectors.sources.keypoint_source import KEYPOINT_SUFFIXES, view_name
from platypose.detectors.sources.video import VIDEO_SUFFIXES, sibling_video
from platypose.lifting.calibration.matching import match_views, normalise_view_name
from platypose.lifting.errors import InputError


@dataclass(frozen=True)
class View:
    """One camera's input: ``source`` (a video, or precomputed keypoints) and the ``video`` it shows, if known."""

    name: str
    source: Path
    video: Path | None


@dataclass(frozen=True)
class Job:
    """One take to lift into ``OUT/<name>/``; ``input`` is how the summary names it."""

    name: str
    input: str
    views: tuple[View, ...]


def job_sources(job: Job) -> list[str]:
    """The input files of ``job`` as absolute paths (what its folder's ``lift.json`` records as its owner)."""
    return [str(Path(v.source).resolve()) for v in job.views]


def is_video(path: Path) -> bool:
    """Whether ``path`` is a file with a video extension."""
    return path.is_file() and path.suffix.lower() in VIDEO_SUFFIXES


def expand_inputs(items: Sequence[str]) -> list[Path]:
    """Paths from INPUT arguments, globs expanded (sorted); InputError for a path or glob that matches nothing."""
    paths: list[Path] = []
    for item in items:
        if Path(item).exists():
            paths.append(Path(item))
            continue
        matches = sorted(glob.glob(item)) if glob.has_magic(item) else []
        if not matches:
            why = " (the glob matches nothing)" if glob.has_magic(item) else ""
            raise InputError(f"{item}: no such file or folder{why}")
        paths += [Path(m) for m in matches]
    return paths


def _videos_in(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if is_video(p))


def _group(videos: list[Path], take_name: str, camera_names: Sequence[str]) -> list[Job]:
    """Loose videos -> one multi-view take if they match distinct cameras, else one job per video."""
    if len(videos) >= 2 and len(camera_names) >= 2:
        try:
            match_views(camera_names, [v.stem for v in videos], allow_missing=True)
        except InputError:
            pass
        else:
            views = tuple(View(v.stem, v, v) for v in videos)
            return [Job(take_name, ", ".join(str(v) for v in videos), views)]
    return [Job(v.stem, str(v), (View(v.stem, v, v),)) for v in videos]


def _unique_names(jobs: list[Job]) -> list[Job]:
    """Jobs named by safe file names (always inside OUT), no two alike (:func:`distinct_names`)."""
    names = distinct_names([safe_name(job.name) for job in jobs])
    return [Job(name, job.input, job.views) for job, name in zip(jobs, names)]


def discover_jobs(paths: Sequence[Path], camera_names: Sequence[str] = ()) -> list[Job]:
    """Jobs for INPUT ``paths`` (videos and folders of videos or of takes); InputError when nothing is found."""
    jobs: list[Job] = []
    loose: list[Path] = []
    for path in paths:
        if is_video(path):
            loose.append(path)
        elif path.is_dir():
            jobs += _group(_videos_in(path), path.resolve().name, camera_names)
            for sub in sorted(p for p in path.iterdir() if p.is_dir()):
                videos = _videos_in(sub)
                jobs += _group(videos, sub.name, camera_names) if videos else []
        elif path.suffix.lower() in KEYPOINT_SUFFIXES:
            raise InputError(f"{path}: keypoint files go after --keypoints; INPUT is a video, a folder or a glob")
        else:
            raise InputError(f"{path}: not a video (known extensions: {' '.join(VIDEO_SUFFIXES)}) nor a folder")
    if loose:
        parents = {p.resolve().parent.name for p in loose}
        jobs = _group(loose, parents.pop() if len(parents) == 1 else loose[0].stem, camera_names) + jobs
    if not jobs:
        raise InputError(f"{', '.join(str(p) for p in paths)}: no video found")
    return _unique_names(jobs)


def _view(source: Path) -> tuple[str, Path]:
    """(view name, source) of a keypoint file or folder; ``cam02_keypoints2d.npz`` (platypose detect) is view cam02."""
    return view_name(source).removesuffix("_keypoints2d"), source


def keypoint_views(keypoints: Path, camera_names: Sequence[str]) -> list[tuple[str, Path]]:
    """(view name, source) pairs of a ``--keypoints`` path: several views when it is a folder of per-view
    sub-folders, or of per-view files named after several calibrated cameras; else one view."""
    if not keypoints.exists():
        raise InputError(f"{keypoints}: no such keypoint file or folder")
    if keypoints.is_file():
        return [_view(keypoints)]
    subfolders = sorted(p for p in keypoints.iterdir() if p.is_dir())
    files = sorted(p for p in keypoints.iterdir() if p.is_file() and p.suffix.lower() in KEYPOINT_SUFFIXES)
    if subfolders:
        return [_view(p) for p in subfolders]
    if len(camera_names) >= 2 and 2 <= len(files) <= len(camera_names):
        cameras = {normalise_view_name(c) for c in camera_names}
        if all(normalise_view_name(_view(p)[0]) in cameras for p in files):
            return [_view(p) for p in files]
    return [_view(keypoints)]


def keypoints_job(keypoints: Path, videos: Sequence[Path], camera_names: Sequence[str]) -> Job:
    """The one job of ``--keypoints``; ``videos`` (INPUT) are paired with the views by name, or the only view."""
    pairs = keypoint_views(keypoints, camera_names)
    if len(pairs) > 1 and not camera_names:
        raise InputError(f"{keypoints}: {len(pairs)} views of keypoints need --cams to place the cameras")
    if len(pairs) > 1:
        try:
            match_views(camera_names, [name for name, _ in pairs], allow_missing=True)
        except InputError as err:
            raise InputError(f"--keypoints {keypoints}: {err}") from None
    by_key = {normalise_view_name(v.stem): v for v in videos}
    views = []
    for name, source in pairs:
        video = videos[0] if len(pairs) == 1 and len(videos) == 1 else by_key.get(normalise_view_name(name))
        views.append(View(name, source, video or sibling_video(source)))
    unused = [str(v) for v in videos if v not in {view.video for view in views}]
    if unused:
        raise InputError(f"--keypoints {keypoints}: video(s) {', '.join(unused)} match none of its views")
    if len(views) > 1:
        name = keypoints.resolve().name
    else:
        name = videos[0].stem if videos else views[0].name
    return Job(safe_name(name), str(keypoints), tuple(views))


def check_views_match(jobs: Sequence[Job], camera_names: Sequence[str], cams: Path) -> None:
    """One InputError, saying how to fix it, when a calibration of several cameras matches no view of any job by
    name (each input would otherwise fail alone with the same mismatch)."""
    if len(camera_names) < 2:
        return
    for job in jobs:
        try:
            match_views(camera_names, [v.name for v in job.views], allow_missing=True)
        except InputError:
            continue
        return
    views = sorted({v.name for job in jobs for v in job.views})
    raise InputError(
        f"{cams}: no camera matches a view by name (cameras {', '.join(camera_names)}; views "
        f"{', '.join(views[:8])}{', ...' if len(views) > 8 else ''}); name each video or keypoint folder after its "
        f"camera (e.g. {camera_names[0]}.mp4) or rename the cameras in the calibration"
    )


def _calibrated(camera_names: Sequence[str], view: str) -> bool:
    """Whether ``view`` can be lifted with the calibration of ``camera_names`` (:func:`match_views`' rule)."""
    try:
        match_views(camera_names, [view], allow_missing=True)
    except InputError:
        return False
    return True


def check_camera_count(jobs: Sequence[Job], camera_names: Sequence[str], cams: Path) -> None:
    """One InputError when more videos than the calibration's cameras are given and some match none of them (a
    calibration of one camera for a take of four: each other camera's video would fail alone, each in its line)."""
    videos = [v for job in jobs for v in job.views]
    strangers = [v.source.name for v in videos if not _calibrated(camera_names, v.name)]
    if len(videos) <= len(camera_names) or not strangers:
        return
    cameras = f"{len(camera_names)} camera{'s' if len(camera_names) > 1 else ''}"
    raise InputError(
        f"{cams}: the calibration has {cameras} ({', '.join(camera_names)}), you gave "
        f"{len(videos)} videos; {', '.join(strangers[:8])}{', ...' if len(strangers) > 8 else ''} match none of its "
        f"cameras: give the calibration of every camera, or lift only the videos it calibrates"
    )
