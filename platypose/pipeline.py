"""One take from its views' 2D tracks to a :class:`~platypose.exporters.result.LiftResult`.

Shared by ``platypose lift`` (``platypose.cli.lift_run`` adds detection, files and job
bookkeeping around it) and the Python API (:func:`platypose.lift`):

1. :func:`match_cameras`: the calibration's camera of each view, matched by name (before
   any detection), then :func:`check_image_size` against each view's image size;
2. :func:`platypose.detectors.take.take_keypoints`: the views' tracks matched across cameras,
   the chosen persons, one clock;
3. :func:`platypose.lifting.take.root_paths`: each person's pelvis path, known or solved;
4. :func:`lift_take`: hypotheses, their median and energy, the per-view reprojection report.

Every step says what it did and warns through a :class:`JobLog`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from platypose.exporters.result import LiftResult
from platypose.lifting.calibration import Calibration
from platypose.lifting.camera import CODEC_BLOCK, SIZE_TOLERANCE, Camera, codec_padded
from platypose.lifting.errors import InputError
from platypose.lifting.flags import person_lines
from platypose.lifting.floor import ESTIMATE, Floor, floor_under
from platypose.lifting.plausibility import plausibility
from platypose.lifting.prior import PriorBundle
from platypose.lifting.rigid import rigid_person
from platypose.lifting.root import presence
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.steady_depth import steady_person
from platypose.lifting.take import lift_persons, reprojection_report
from platypose.lifting.world import level_on_floor


class JobLog:
    """Timestamped lines of one lift (``OUT/<name>/log.txt`` for the CLI), and its warnings and notes for the result's
    meta."""

    def __init__(self) -> None:
        self.started = time.perf_counter()
        self.lines: list[str] = []
        self.warnings: list[str] = []
        self.notes: list[str] = []

    def __call__(self, message: str) -> None:
        self.lines.append(f"[{time.perf_counter() - self.started:7.1f} s] {message}")

    def warning(self, message: str) -> None:
        """Log a warning and keep it for the result's meta."""
        self.warnings.append(message)
        self(f"warning: {message}")

    def note(self, message: str) -> None:
        """Log what the lift assumed (not a fault: no warning) and keep it for the result's ``meta["notes"]``."""
        self.notes.append(message)
        self(message)

    def write(self, path: Path) -> None:
        """Write the log atomically."""
        from platypose.lifting.atomic import write_text_atomic

        write_text_atomic(path, "\n".join(self.lines) + "\n")


FLOOR_PASS_SAMPLES = 10  # hypotheses of the quick lift a one-camera floor is estimated under
FLOOR_PASS_PERSONS = 4  # persons (present longest) whose standing ankles it is estimated from
QUICK_LIFT = "the floor's quick lift"  # what progress calls the quick lift's windows


def numpy_arrays(shape: tuple[int, ...], name: str) -> np.ndarray:
    """An in-memory float32 array for one of the result's long arrays (``name``: hypotheses, median, energy)."""
    return np.empty(shape, np.float32)


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
    calibration_word: str = "cams",
) -> list[Camera]:
    """The matched ``cameras`` checked against the views' image sizes (height, width), each image at least
    ``MIN_IMAGE_SIDE`` a side and each focal length warned about when no lens has it, or without a calibration
    the default camera of a single view (a note: one uncalibrated phone is the common case, not a fault); InputError
    for several views without one.

    ``calibration_word`` is how the messages name the missing calibration (the CLI says ``--cams``).
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
    from platypose.lifting.calibration.defaults import default_camera

    log.note(f"no {calibration_word}: a level camera at the origin with a 53 degree diagonal field of view is assumed")
    return [default_camera(names[0], *image_sizes[0])]


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
    keypoints: np.ndarray,
    times: np.ndarray,
    track_ids: np.ndarray,
    cameras: Sequence[Camera],
    roots: Sequence[np.ndarray | None],
    sampler: SamplerConfig,
    windows: WindowSettings,
    arrays: Callable[[tuple[int, ...], str], object] = numpy_arrays,
    progress: Callable[[list[int] | str, int, int], None] | None = None,
    log: JobLog | None = None,
    floor: Floor | str | None = None,
    everyone: np.ndarray | None = None,
    lifter: Callable = lift_persons,
) -> LiftResult:
    """The LiftResult of a take: keypoints (C, T, P, 17, 3) on ``times`` (T,) of persons ``track_ids`` (P,),
    seen by ``cameras``, each person's root path known (T, 3) or None (solved per hypothesis).

    ``arrays(shape, name)`` makes the result's long arrays (default: in memory; the CLI's are files).
    ``progress(group, done, total)`` counts the windows lifted of each group of persons (``group``: their indices,
    or ``QUICK_LIFT`` for the windows of the floor's quick lift).
    ``floor`` (:func:`platypose.lifting.floor.floor_for_lift`): a Floor grounds every hypothesis inside the
    sampler; ``ESTIMATE`` (one camera) first estimates it under a quick ungrounded lift (:func:`quick_floor`)
    and grounds on it, or lifts without a floor where too few standing ankles are found; None: no floor.
    ``everyone`` (1, T, P', 17, 3): the keypoints of everyone in the take when ``keypoints`` hold only the persons
    chosen, so the estimated floor does not depend on whom the user chose. The result's ``meta`` holds ``prior_sha256``, ``reprojection_px`` (per view), ``floor``, ``plausibility`` (per
    person, :mod:`platypose.lifting.plausibility`, with its ``flag_text``; logged, not a warning) and ``rigid_bones`` (per person,
    :func:`platypose.lifting.rigid.rigid_person`: every hypothesis and the median get one length per bone over
    the clip); the caller adds its own. ``lifter`` lifts the persons (``lift_persons``, or the same spread over
    pieces: ``platypose.cli.split_join.SplitLifter``). With an estimated floor every output is moved into the estimated world
    (:mod:`platypose.lifting.world`: z = 0 the floor, z up, the camera at its estimated height and pitch), which
    ``meta["floor"]["frame"]`` says.
    """
    log = log if log is not None else JobLog()
    fps = 1.0 / float(np.median(np.diff(times))) if len(times) > 1 else prior.fps
    absent = ~presence(keypoints, times, windows.max_gap)  # (P, T): unseen up to windows.max_gap is lifted through
    floor_meta = None
    if floor == ESTIMATE:
        if everyone is None:
            floor, floor_meta = quick_floor(
                prior, keypoints, times, absent, cameras, roots, sampler, windows, fps, log, progress, lifter
            )
        else:
            missing = ~presence(everyone, times)
            others = [None] * everyone.shape[2]  # solved: a known root path belongs to a chosen person only
            floor, floor_meta = quick_floor(
                prior, everyone, times, missing, cameras, others, sampler, windows, fps, log, progress, lifter
            )
    if isinstance(floor, Floor):
        sampler = replace(sampler, floor=floor.plane)
        floor_meta = floor_meta or floor.as_dict()
        log(f"floor ({floor.source}): {' '.join(f'{v:g}' for v in floor.plane)} (n . x + d = 0), grounding on")
    started = time.perf_counter()
    (P, T), N = absent.shape, sampler.samples
    hypotheses = arrays((P, N, T, 17, 3), "hypotheses")
    median = arrays((P, T, 17, 3), "median")
    energy = arrays((P, N, T), "energy")
    lifter(prior, keypoints, times, cameras, roots, absent, sampler, windows, hypotheses, median, energy, progress)
    log(f"lifted {N} hypotheses in {time.perf_counter() - started:.1f} s")
    if len(cameras) == 1 and sampler.floor is not None:  # one grounded view: steady each solved root's depth
        for p, track in ((p, t) for p, t in enumerate(track_ids) if roots[p] is None):
            seen = (np.nan_to_num(keypoints[0, :, p, :, 2]) > 0).sum(axis=-1)  # joints seen per frame
            moved = steady_person(hypotheses, p, cameras[0], fps, sampler.floor, seen, times)
            log(f"person {track}: depth steadied, pelvis moved along its ray by up to {moved:.2f} m")
    rigid = {}
    for p, track in enumerate(track_ids):
        began = time.perf_counter()
        rigid[f"p{track}"] = stats = rigid_person(hypotheses, median, keypoints, cameras, p, fps, sampler.floor)
        log(
            f"person {track}: made rigid in {time.perf_counter() - began:.1f} s (the sampler's median motion "
            f"stretched its bones by up to {1000 * stats['stretch_m']:.0f} mm); its joints moved "
            f"{1000 * stats['moved_m']:.0f} mm (median), {1000 * stats['moved_max_m']:.0f} mm at most"
        )
    report = report_reprojection(median, keypoints, cameras, log)
    persons = plausibility(hypotheses, keypoints, floor, fps, median=median, cameras=cameras)
    for track, person in zip(track_ids, persons):
        person["track_id"] = int(track)
    for line in person_lines(persons, track_ids):  # said once: the console shows them from the result
        log(line)
    if floor_meta and floor_meta["source"] == "estimated":  # outputs in the estimated world: z = 0 the floor, z up
        camera, floor_meta = level_on_floor(floor, floor_meta, cameras[0], (hypotheses, median))
        cameras = [camera]
        log(f"outputs in the {floor_meta['frame']}")
    meta = {
        "prior_sha256": prior.checksum,
        "reprojection_px": report,
        "floor": floor_meta,
        "plausibility": persons,
        "rigid_bones": rigid,
        "notes": list(log.notes),
    }
    return LiftResult(
        hypotheses=hypotheses,
        median=median,
        keypoints2d=np.moveaxis(keypoints, 2, 1),
        frame_times=times,
        fps=fps,
        track_ids=track_ids,
        cameras=tuple(cameras),
        energy=energy,
        meta=meta,
    )


def quick_floor(
    prior: PriorBundle,
    keypoints: np.ndarray,
    times: np.ndarray,
    absent: np.ndarray,
    cameras: Sequence[Camera],
    roots: Sequence[np.ndarray | None],
    sampler: SamplerConfig,
    windows: WindowSettings,
    fps: float,
    log: JobLog,
    progress: Callable[[list[int] | str, int, int], None] | None = None,
    lifter: Callable = lift_persons,
) -> tuple[Floor | None, dict | None]:
    """The floor under a one-camera take (keypoints (1, T, P, 17, 3), persons ``absent`` (P, T)) and its ``meta``
    entry, estimated (:func:`platypose.lifting.floor.floor_under`) under the median motions of a quick lift
    without a floor: ``FLOOR_PASS_SAMPLES`` hypotheses of the ``FLOOR_PASS_PERSONS`` persons present longest;
    None, None (logged) when too few standing ankles are found. ``progress(QUICK_LIFT, done, total)`` counts its
    windows."""
    if len(cameras) != 1:
        return None, None
    began = time.perf_counter()
    persons = np.argsort(absent.sum(axis=1), kind="stable")[:FLOOR_PASS_PERSONS]
    quick = replace(sampler, samples=min(sampler.samples, FLOOR_PASS_SAMPLES), floor=None)
    P, T = len(persons), len(times)
    hypotheses, energy = np.empty((P, quick.samples, T, 17, 3), np.float32), np.empty((P, quick.samples, T), np.float32)
    median = np.empty((P, T, 17, 3), np.float32)
    kept = keypoints[:, :, persons]
    lifter(
        prior,
        kept,
        times,
        cameras,
        [roots[p] for p in persons],
        absent[persons],
        quick,
        windows,
        hypotheses,
        median,
        energy,
        None if progress is None else (lambda group, done, total: progress(QUICK_LIFT, done, total)),
    )
    floor, meta = floor_under(median, cameras[0], fps, kept[0])
    seconds = time.perf_counter() - began
    if floor is None:
        log(f"floor: too few standing ankles to estimate it under a quick lift ({seconds:.1f} s); lifting without one")
    else:
        log(
            f"floor estimated under a quick lift of {quick.samples} hypotheses ({seconds:.1f} s): camera "
            f"{meta['camera_height_m']:.2f} m above it, pitched {meta['camera_pitch_deg']:.1f} degrees down "
            f"({meta['stance_points']} standing ankles); --floor z=H or a calibration sets it instead"
        )
    return floor, meta


def report_reprojection(median, keypoints: np.ndarray, cameras: Sequence[Camera], log: JobLog) -> dict[str, float]:
    """:func:`platypose.lifting.take.reprojection_report` logged: one line of per-view pixels, then its warnings."""
    report, warnings = reprojection_report(median, keypoints, cameras)
    if report:
        log(
            "median motion against the keypoints (median px per view): "
            + ", ".join(f"{name} {value:.1f}" for name, value in report.items())
        )
    for warning in warnings:
        log.warning(warning)
    return report
