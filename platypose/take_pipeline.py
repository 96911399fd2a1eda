"""One take from its views to a :class:`~platypose.exporters.result.LiftResult`: the steps ``platypose lift`` and
``platypose.lift`` share.

:func:`run_take` runs them in order, each saying what it did through a :class:`~platypose.pipeline.JobLog`:

1. cameras: the calibration's camera of each view, matched by name before anything is read, and checked against
   each video's image size (read from its header) before anything is detected;
2. 2D: each view read or detected by the caller's ``read`` (the command caches detections and shows progress,
   the API does neither); a view's notes (a truncated video) become warnings;
3. the cameras checked against the views' image sizes (or one view's default camera);
4. sync: each camera's time offset (:mod:`platypose.lifting.sync_choice`);
5. one clock: persons matched across views, the ``persons`` choice (:func:`platypose.detectors.take.take_keypoints`);
6. roots: each person's pelvis path given, triangulated or solved (:func:`platypose.lifting.take.root_paths`);
7. lift, rigid people, the reprojection report and plausibility (:func:`platypose.pipeline.lift_take`);
8. meta: version, input, arguments, which rule picked whom (``persons``), sync, roots, timings, warnings.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

from platypose.detectors.types import PoseTrack2D
from platypose.exporters.result import LiftResult
from platypose.lifting.calibration import Calibration
from platypose.lifting.prior import PriorBundle
from platypose.lifting.settings import TakeSettings
from platypose.pipeline import JobLog, check_image_size, lift_take, match_cameras, numpy_arrays, view_cameras

Reader = Callable[[Path], tuple[PoseTrack2D, str]]  # a view's source -> its tracks and how they were obtained


def run_take(
    views: Sequence[tuple[str, Path]],
    calibration: Calibration | None,
    take: TakeSettings,
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
    camera), lifted as ``take`` says with the prior ``prior()`` gives (called once the inputs are read and checked).

    ``what`` names the take in errors, ``described`` the calibration (its file), ``cams_option`` the option a
    missing calibration is asked for by (``--cams`` in the command). ``arguments`` go into ``meta``
    as given; ``arrays``, ``progress`` and ``lifter`` (None: the usual) as :func:`platypose.pipeline.lift_take` takes them. InputError for bad
    input, before any lifting.
    """
    from platypose import __version__
    from platypose.detectors.person_choice import describe_choice
    from platypose.detectors.take import take_keypoints
    from platypose.detectors.view_agreement import disagreeing_views
    from platypose.lifting.floor import ESTIMATE, floor_for_lift, parse_floor
    from platypose.lifting.sync_choice import synchronise
    from platypose.lifting.take import root_kinds

    names, sources = [name for name, _ in views], [source for _, source in views]
    cameras = None if calibration is None else match_cameras(calibration, names, what, described)
    if cameras is not None:  # a wrong calibration is found before anything is detected: sizes from video headers
        for camera, source in zip(cameras, sources):
            size = _video_size(source)
            if size is not None:
                check_image_size(camera, size, str(source), JobLog())  # raises for a mismatch; small ones warn later
    floor = floor_for_lift(parse_floor(take.floor), None if calibration is None else calibration.meta)
    started = time.perf_counter()
    tracks = [_read_view(read, name, source, log) for name, source in views]
    timings = {"keypoints_s": time.perf_counter() - started}
    sizes = [t.image_size for t in tracks]
    cameras = view_cameras(cameras, sizes, names, [str(s) for s in sources], what, log, cams_option)
    synced = synchronise(
        take.sync, [t.keypoints for t in tracks], [t.frame_times for t in tracks], cameras, log, log.warning
    )
    keypoints, times, track_ids = take_keypoints(tracks, synced.cameras, take.persons, what)
    everyone = None  # an estimated floor comes from everyone in the take, not only from the persons chosen
    if floor == ESTIMATE and len(synced.cameras) == 1 and take.persons != "all":
        everyone = take_keypoints(tracks, synced.cameras, "all", what)[0]
    swapped = disagreeing_views(keypoints, [c.name for c in synced.cameras])
    if swapped:
        log.warning(swapped)
    chosen = describe_choice(take.persons, [int(t) for t in track_ids])
    log(f"{keypoints.shape[0]} view(s), {len(times)} frames, {len(track_ids)} person(s) ({chosen})")
    roots = _roots(keypoints, times, synced.cameras, take, log)
    bundle = prior()
    started = time.perf_counter()
    result = lift_take(
        bundle,
        keypoints,
        times,
        track_ids,
        synced.cameras,
        roots,
        take.sampler,
        take.windows,
        arrays,
        progress,
        log,
        floor,
        everyone,
        **({} if lifter is None else {"lifter": lifter}),
    )
    timings["lift_s"] = time.perf_counter() - started
    meta = {
        "version": __version__,
        "input": what,
        "arguments": arguments if arguments is not None else {},
        **result.meta,
        "persons": chosen,
        "sync": synced.record(),
        "root": root_kinds(roots, take.root_trajectory is not None),
        "timings": timings,
        "warnings": log.warnings,
    }
    return replace(result, meta=meta)


def take_settings(**values: object) -> TakeSettings:
    """:class:`TakeSettings` from ``values`` (natural Python values or the command's strings), with the persons
    choice checked as the detectors read it: the one check of a take's settings the command and the API both make
    before any work (InputError naming the field)."""
    from platypose.detectors.tracking import persons_count

    take = TakeSettings(**values)
    persons_count(take.persons)
    return take


def _video_size(source: Path) -> tuple[int, int] | None:
    """A video view's upright image size (height, width) from its header and first frame; None for keypoints."""
    from platypose.detectors.sources import is_keypoint_source
    from platypose.media import video_info

    path = Path(source)
    if is_keypoint_source(path) or not path.is_file():
        return None
    return video_info(path).image_size


def _read_view(read: Reader, name: str, source: Path, log: JobLog) -> PoseTrack2D:
    """One view's tracks, logged with how long they took; their notes become warnings."""
    started = time.perf_counter()
    tracks, how = read(source)
    log(
        f"view {name}: {source} -> {tracks.num_frames} frames, {tracks.num_persons} track(s), {how}, "
        f"{time.perf_counter() - started:.1f} s"
    )
    for note in tracks.notes:
        log.warning(note)
    return tracks


def _roots(keypoints, times, cameras, take: TakeSettings, log: JobLog) -> list:
    """Per person: the pelvis path of ``take.root_trajectory`` (T, 3), a triangulated one, or None (solved)."""
    from platypose.lifting.take import root_paths

    given = None
    if take.root_trajectory is not None:
        from platypose.detectors.root_file import read_root_trajectory

        log(f"root trajectory from {take.root_trajectory}")
        given = list(read_root_trajectory(take.root_trajectory, times, keypoints.shape[2]))
    return root_paths(keypoints, times, cameras, take.root, given, say=log)
