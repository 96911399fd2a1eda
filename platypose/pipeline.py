"""One take from its views to a :class:`~platypose.exporters.result.LiftResult`: the steps ``platypose lift`` and
``platypose.lift`` share (the command adds detection caches, files and job bookkeeping around them).

:func:`run_take` runs them in order, each saying what it did through a :class:`~platypose.lifting.job_log.JobLog`:

1. cameras: the calibration's camera of each view, matched by name before anything is read (:func:`match_cameras`),
   and checked against each video's image size (read from its header) before anything is detected;
2. 2D: each view read or detected by the caller's ``read`` (the command caches detections and shows progress,
   the API does neither); a view's notes (a truncated video) become warnings;
3. the cameras checked against the views' image sizes, or one view's default camera (:func:`view_cameras`);
4. sync: each camera's time offset (:mod:`platypose.lifting.sync.choice`);
5. one clock: persons matched across views, the ``persons`` choice (:func:`platypose.detectors.persons.take.take_keypoints`);
6. roots: each person's pelvis path given, triangulated or solved (:func:`platypose.lifting.tracks.persons.root_paths`);
7. the floor, the lift, and everything after sampling (:func:`lift_take`: :func:`platypose.lifting.tracks.quick_floor.quick_floor`,
   :func:`platypose.lifting.tracks.persons.lift_persons`, :func:`platypose.lifting.finish.steps.finish_take`);
8. meta: version, input, arguments, which rule picked whom (``persons``), sync, roots, timings, warnings.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from platypose.detectors.types import PoseTrack2D
from platypose.detectors.view_reader import ViewRead
from platypose.exporters.result import LiftResult
from platypose.lifting.calibration import Calibration
from platypose.lifting.camera import CODEC_BLOCK, SIZE_TOLERANCE, Camera, codec_padded
from platypose.lifting.errors import InputError
from platypose.lifting.floor import Floor, FloorToEstimate
from platypose.lifting.job_log import JobLog
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.settings import TakeSettings
from platypose.lifting.take import Take
from platypose.lifting.tracks.persons import lift_persons
from platypose.lifting.tracks.quick_floor import quick_floor
from platypose.lifting.tracks.take_lift import lift_and_finish, numpy_arrays

if TYPE_CHECKING:
    from platypose.lifting.calibration.scene.view_camera import AssumedCamera

Reader = Callable[[Path], ViewRead]  # a view's source -> its tracks and how they were obtained


def run_take(
    views: Sequence[tuple[str, Path]],
    calibration: Calibration | None,
    settings: TakeSettings,
    read: Reader,
    prior: Callable[[], PriorBundle],
    log: JobLog,
    *,
    what: str,
    described: str = "the cameras given",
    cams_option: str = "cams",
    arguments: dict | None = None,
    arrays: Callable[[tuple[int, ...], str], object] = numpy_arrays,
    progress: Callable[[list[int], int, int], None] | None = None,
    lifter: Callable | None = None,
) -> LiftResult:
    """The LiftResult of the take seen by ``views`` (name, source) under ``calibration`` (None: one view, a default
    camera), lifted as ``settings`` say with the prior ``prior()`` gives (called once the inputs are read and checked).

    ``what`` names the take in errors, ``described`` the calibration (its file), ``cams_option`` the option a
    missing calibration is asked for by (``--cams`` in the command). ``arguments`` go into ``meta``
    as given; ``arrays``, ``progress`` and ``lifter`` (None: :func:`lift_persons`) as :func:`lift_take` takes them. InputError for bad
    input, before any lifting.
    """
    from platypose import __version__
    from platypose.detectors.persons.person_choice import describe_choice
    from platypose.detectors.persons.take import take_keypoints
    from platypose.detectors.persons.view_agreement import disagreeing_views
    from platypose.lifting.floor import floor_for_lift
    from platypose.lifting.sync.choice import synchronise
    from platypose.lifting.tracks.persons import root_kinds

    names, sources = [name for name, _ in views], [source for _, source in views]
    cameras = None if calibration is None else match_cameras(calibration, names, what, described)
    if cameras is not None:  # a wrong calibration is found before anything is detected: sizes from video headers
        for camera, source in zip(cameras, sources):
            size = _video_size(source)
            if size is not None:
                check_image_size(camera, size, str(source), JobLog())  # raises for a mismatch; small ones warn later
    floor = floor_for_lift(settings.floor_choice, None if calibration is None else calibration.meta)
    started = time.perf_counter()
    tracks = [_read_view(read, name, source, log) for name, source in views]
    timings = {"keypoints_s": time.perf_counter() - started}
    sizes = [t.image_size for t in tracks]
    assumed = None
    if cameras is None and len(views) == 1:
        started = time.perf_counter()
        assumed = _assumed_camera(names[0], sources[0], tracks[0])
        timings["scene_camera_s"] = time.perf_counter() - started
        if assumed is not None and assumed.level_known and isinstance(floor, FloorToEstimate):
            floor = FloorToEstimate(height_only=True)
    cameras = view_cameras(
        cameras, sizes, names, [str(s) for s in sources], what, log, calibration_word=cams_option, assumed=assumed
    )
    synced = synchronise(
        settings.sync, [t.keypoints for t in tracks], [t.frame_times for t in tracks], cameras, log, log.warning
    )
    keypoints, times, track_ids = take_keypoints(tracks, synced.cameras, settings.persons, what)
    everyone = None  # an estimated floor comes from everyone in the take, not only from the persons chosen
    if isinstance(floor, FloorToEstimate) and len(synced.cameras) == 1 and settings.persons != "all":
        everyone = take_keypoints(tracks, synced.cameras, "all", what)
    swapped = disagreeing_views(keypoints, [c.name for c in synced.cameras])
    if swapped:
        log.warning(swapped)
    chosen = describe_choice(settings.persons, [int(t) for t in track_ids])
    log(f"{keypoints.shape[0]} view(s), {len(times)} frames, {len(track_ids)} person(s) ({chosen})")
    roots = _roots(keypoints, times, synced.cameras, settings, log)
    lifted = {"sampler": settings.sampler, "windows": settings.windows}
    take = Take.on_clock(keypoints, times, track_ids, synced.cameras, roots, **lifted)
    if everyone is not None:  # solved: a known root path belongs to a chosen person only
        others, _, others_ids = everyone
        everyone = Take.on_clock(others, times, others_ids, synced.cameras, [None] * others.shape[2], **lifted)
    bundle = prior()
    started = time.perf_counter()
    result = lift_take(
        bundle,
        take,
        floor=floor,
        everyone=everyone,
        arrays=arrays,
        progress=progress,
        log=log,
        lifter=lifter or lift_persons,
    )
    timings["lift_s"] = time.perf_counter() - started
    meta = {
        "version": __version__,
        "input": what,
        "arguments": arguments if arguments is not None else {},
        **result.meta,
        "persons": chosen,
        "sync": synced.record(),
        **({} if assumed is None else {"camera": assumed.record}),
        "root": root_kinds(roots, settings.root_trajectory is not None),
        "timings": timings,
        "warnings": log.warnings,
    }
    return replace(result, meta=meta)


def match_cameras(calibration: Calibration, names: Sequence[str], what: str, against: str) -> list[Camera]:
    """The camera of ``calibration`` (read from ``against``) matching each view name of ``names``; InputError
    (calibration mismatch, naming ``what``) when a view has none."""
    from platypose.lifting.calibration.matching import match_views

    try:
        pairs = match_views(calibration.names, list(names), allow_missing=True)
    except InputError as err:
        raise InputError(f"{what}: calibration mismatch with {against}: {err}") from None
    by_view = {view: calibration.camera(camera) for camera, view in pairs.items()}
    return [by_view[name] for name in names]


def view_cameras(
    cameras: Sequence[Camera] | None,
    image_sizes: Sequence[tuple[int, int]],
    names: Sequence[str],
    sources: Sequence[str],
    what: str,
    log: JobLog,
    *,
    calibration_word: str = "cams",
    assumed: AssumedCamera | None = None,
) -> list[Camera]:
    """The matched ``cameras`` checked against the views' image sizes (height, width), each image at least
    ``MIN_IMAGE_SIDE`` a side and each focal length warned about when no lens has it, or without a calibration
    the default camera of a single view (a note: one uncalibrated phone is the common case, not a fault); InputError
    for several views without one.

    ``calibration_word`` is how the messages name the missing calibration (the CLI says ``--cams``). ``assumed``:
    the single view's camera from its scene (:func:`_assumed_camera`), used instead of the default and its lines
    logged as notes.
    """
    from platypose.lifting.calibration.plausible import camera_doubts, check_image_side

    for size, source in zip(image_sizes, sources):
        check_image_side(size, source)
    if cameras is not None:
        for camera, size, source in zip(cameras, image_sizes, sources):
            check_image_size(camera, size, source, log)
        for doubt in (line for camera in cameras for line in camera_doubts(camera)):
            log.warning(doubt)
        return list(cameras)
    if len(names) > 1:
        raise InputError(f"{what}: {len(names)} views need {calibration_word} to place the cameras")
    if assumed is not None:
        for line in assumed.lines:
            log.note(f"no {calibration_word}: {line}")
        return [assumed.camera]
    from platypose.lifting.calibration.defaults import default_camera

    log.note(f"no {calibration_word}: a level camera at the origin with a 53 degree diagonal field of view is assumed")
    return [default_camera(names[0], *image_sizes[0])]


def _assumed_camera(name: str, source: Path, track: PoseTrack2D) -> AssumedCamera | None:
    """The camera of the one uncalibrated view ``name`` from its video's scene
    (:func:`platypose.detectors.sources.scene_frames.view_camera`): the video detected, or for keypoints the video
    they were made from where it lies beside them (:func:`platypose.detectors.sources.video.sibling_video`) at their
    image size; None where there is no such video."""
    from platypose.detectors.sources.keypoint_source import is_keypoint_source
    from platypose.detectors.sources.scene_frames import view_camera
    from platypose.detectors.sources.video import VIDEO_SUFFIXES, sibling_video

    video = Path(source)
    if is_keypoint_source(video):
        video = sibling_video(video)
        if video is None or _video_size(video) != tuple(track.image_size):  # keypoints on other pixels: not its scene
            return None
    if not (video.is_file() and video.suffix.lower() in VIDEO_SUFFIXES):
        return None
    return view_camera(video, name, track)


def check_image_size(camera: Camera, image_size: tuple[int, int], source: str, log: JobLog) -> None:
    """Warn about a small calibrated/actual image size difference; InputError for a large one. A calibration of the
    coded frame (each side the video's rounded up to a multiple of 16: the codec pads right and bottom, the decoder
    crops them) has the video's very pixel coordinates: a note, not a warning."""
    if tuple(camera.size) == tuple(image_size):
        return
    relative = max(abs(a - b) / b for a, b in zip(camera.size, image_size))
    said = (
        f"calibration says {camera.width}x{camera.height} px for camera {camera.name}, "
        f"{source} is {image_size[1]}x{image_size[0]}"
    )
    if codec_padded(camera.size, image_size):
        log.note(f"{said}: the codec's padding to a multiple of {CODEC_BLOCK}, the same pixels")
        return
    if relative > SIZE_TOLERANCE:
        raise InputError(f"{source}: calibration mismatch: {said}")
    log.warning(f"{said}; pixels used as they are (the principal point is what matters)")


def lift_take(
    prior: PriorBundle,
    take: Take,
    *,
    floor: Floor | FloorToEstimate | None = None,
    everyone: Take | None = None,
    arrays: Callable[[tuple[int, ...], str], object] = numpy_arrays,
    progress: Callable[[list[int] | str, int, int], None] | None = None,
    log: JobLog | None = None,
    lifter: Callable = lift_persons,
) -> LiftResult:
    """The LiftResult of ``take`` (:class:`~platypose.lifting.take.Take`: keypoints (C, T, P, 17, 3) on one clock,
    its persons, cameras, root paths, presence, and the sampler's and windows' settings).

    ``arrays(shape, name)`` makes the result's long arrays (default: in memory; the CLI's are files).
    ``progress(group, done, total)`` counts the windows lifted of each group of persons (``group``: their indices,
    or :data:`~platypose.lifting.tracks.quick_floor.QUICK_LIFT` for the windows of the floor's quick lift).
    ``floor`` (:func:`platypose.lifting.floor.floor_for_lift`): a Floor grounds every hypothesis inside the
    sampler (its plane replaces ``take.sampler.floor``) and is the floor finishing keeps them on;
    :class:`~platypose.lifting.floor.FloorToEstimate` (one camera) first estimates it under a quick ungrounded lift
    (:func:`quick_floor`) and grounds on it, or lifts without a floor where too few standing ankles are found
    (``height_only``: the floor level in the camera's world, whose roll and pitch are the scene's: only its height
    estimated); None: no floor. ``everyone``: the take of everyone in it (root paths solved) when ``take`` holds
    only the persons chosen, so the estimated floor does not depend on whom the user chose. The result's ``meta``
    holds ``prior_sha256``, ``reprojection_px`` (per view), ``floor``, ``plausibility`` (per person,
    :mod:`platypose.lifting.checks.plausibility`, with its ``flag_text``; logged, not a warning) and ``rigid_bones``
    (per person, :func:`platypose.lifting.finish.rigid.rigid_person`: every hypothesis and the median get one length
    per bone over the clip); the caller adds its own. ``lifter`` lifts the persons (:func:`lift_persons`, or the same
    spread over pieces: ``platypose.cli.runs.split.SplitLifter``); the floor's quick lift is always the whole take's
    (:func:`lift_persons`), so a split take stands on the floor and in the world of the unsplit one. With an estimated
    floor every output is moved into the estimated world (:mod:`platypose.lifting.finish.world`: z = 0 the floor, z up,
    the camera at its estimated height and pitch), which ``meta["floor"]["frame"]`` says.
    """
    log = log if log is not None else JobLog()
    if isinstance(floor, FloorToEstimate):
        on = everyone if everyone is not None else take
        floor = quick_floor(prior, on, log=log, progress=progress, height_only=floor.height_only)  # whole: one floor
    lifted = lift_and_finish(prior, take, floor=floor, log=log, arrays=arrays, progress=progress, lifter=lifter)
    finished = lifted.finished
    meta = {
        "prior_sha256": prior.checksum,
        "reprojection_px": finished.reprojection_px,
        "floor": finished.floor,
        "plausibility": finished.plausibility,
        "rigid_bones": finished.rigid_bones,
        "notes": list(log.notes),
    }
    return LiftResult(
        hypotheses=lifted.hypotheses,
        median=lifted.median,
        keypoints2d=np.moveaxis(take.keypoints, 2, 1),
        frame_times=take.times,
        fps=lifted.fps,
        track_ids=take.track_ids,
        cameras=finished.cameras,
        energy=lifted.energy,
        meta=meta,
    )


def _video_size(source: Path) -> tuple[int, int] | None:
    """A video view's upright image size (height, width) from its header and first frame; None for keypoints."""
    from platypose.detectors.sources.keypoint_source import is_keypoint_source
    from platypose.media import video_info

    path = Path(source)
    if is_keypoint_source(path) or not path.is_file():
        return None
    return video_info(path).image_size


def _read_view(read: Reader, name: str, source: Path, log: JobLog) -> PoseTrack2D:
    """One view's tracks, logged with how long they took; their notes become warnings."""
    started = time.perf_counter()
    view = read(source)
    tracks = view.tracks
    log(
        f"view {name}: {source} -> {tracks.num_frames} frames, {tracks.num_persons} track(s), {view.how}, "
        f"{time.perf_counter() - started:.1f} s"
    )
    for note in tracks.notes:
        log.warning(note)
    return tracks


def _roots(keypoints, times, cameras, settings: TakeSettings, log: JobLog) -> list:
    """Per person: the pelvis path of ``settings.root_trajectory`` (T, 3), a triangulated one, or None (solved)."""
    from platypose.lifting.tracks.persons import root_paths

    given = None
    if settings.root_trajectory is not None:
        from platypose.detectors.sources.root_file import read_root_trajectory

        log(f"root trajectory from {settings.root_trajectory}")
        given = list(read_root_trajectory(settings.root_trajectory, times, keypoints.shape[2]))
    return root_paths(keypoints, times, cameras, settings.root, given, say=log)
