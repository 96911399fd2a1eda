"""The Python API: :func:`lift` one take, :func:`load_result` of an earlier lift, :class:`Prior` to load once.

``platypose.lift`` runs the pipeline of ``platypose lift`` (:mod:`platypose.pipeline`) on one
take and returns the :class:`~platypose.exporters.result.LiftResult` in memory; nothing is
written. docs/api.md shows it end to end.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, replace
from pathlib import Path

from platypose.exporters.result import LiftResult
from platypose.lifting.calibration import Calibration
from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError
from platypose.lifting.lift import WindowSettings
from platypose.lifting.prior import PriorBundle
from platypose.lifting.runtime import PriorSettings
from platypose.lifting.sampler import SamplerConfig
from platypose.pipeline import JobLog


class Prior:
    """Motion priors: ``Prior.load(...)`` gives a :class:`~platypose.lifting.prior.PriorBundle` to pass to
    :func:`lift` (load it once for many takes)."""

    @staticmethod
    def load(path: str | Path | None = None, device: str = "cpu", runtime: str = "auto") -> PriorBundle:
        """The prior at ``path`` (None: the shipped one) on ``device`` (cpu, cuda, auto), its network run by
        ``runtime`` (auto, float32, bfloat16, onnx)."""
        return PriorSettings(Path(path) if path is not None else None, device, runtime).load()


def load_result(path: str | Path) -> LiftResult:
    """The LiftResult of a ``.npz`` written by ``platypose lift`` (or by :func:`platypose.exporters.export`)."""
    from platypose.exporters.npz import read_npz

    return read_npz(path)


def lift(
    views: str | Path | Sequence[str | Path],
    cams: str | Path | Calibration | Sequence[Camera] | None = None,
    *,
    prior: PriorBundle | str | Path | None = None,
    sampler: SamplerConfig | None = None,
    windows: WindowSettings | None = None,
    persons: str = "all",
    root: str = "auto",
    root_trajectory: str | Path | None = None,
    floor: str = "auto",
    sync: str | Path | Mapping[str, float] = "none",
    detector: str | Path | None = None,
    stride: int = 1,
    threads: int | None = None,
    fps: float | None = None,
    image_size: tuple[int, int] | None = None,
    say: Callable[[str], None] | None = None,
    **sampler_fields: object,
) -> LiftResult:
    """Lift the people of one take to 3D motion hypotheses, as ``platypose lift`` does for one input.

    ``views``: one path per camera, each a video (detected with ``detector``, default the
    bundled MoveNet) or precomputed keypoints (an OpenPose folder, our npz / CSV, MMPose
    JSON); its name (file stem, folder name without ``_json``) is matched to the camera's.
    ``cams``: a calibration file, a loaded :class:`Calibration` or a list of cameras; None
    for one view (a level camera at the origin is assumed). ``prior``: a loaded
    :class:`Prior` (load it once for many takes) or a checkpoint path (None: the shipped
    prior). ``sampler`` / ``windows``: settings objects; keyword arguments named after
    :class:`SamplerConfig` fields (``samples=20, seed=1``) replace those fields.
    ``persons``: all, largest or N; ``root``: auto, triangulate or solve;
    ``root_trajectory``: a known pelvis path file. ``floor``: auto (the calibration's z = 0; without one,
    one camera: estimated under a quick lift, then grounded on), z=H, nx,ny,nz,d or none, as ``--floor``.
    ``sync``: how the views are put on one clock, as ``--sync``: none (the calibration's time offsets), auto
    (each view's offset estimated from its keypoints, logged with its confidence), an offsets JSON file, or a mapping
    ``{"cam01": 0.0, "cam02": 0.12}`` of seconds added to each view's frame times. ``stride``: detect
    every N-th frame; ``threads``: the detector's threads. ``fps`` and ``image_size`` (height, width): for
    keypoints without a video beside them (as ``--fps``, ``--image-size``). ``say`` receives the log's lines.

    Returns the LiftResult (hypotheses (P, N, T, 17, 3) world metres, median, 2D keypoints,
    cameras with their time offsets, ``meta`` with the arguments, the settings, the offsets used
    (``meta["sync"]``) and the log's warnings); InputError for bad input, as the CLI.
    """
    from platypose import __version__
    from platypose.detectors.sources import view_name
    from platypose.detectors.take import take_keypoints
    from platypose.lifting.floor import floor_for_lift, parse_floor
    from platypose.lifting.sync_choice import check_choice, synchronise
    from platypose.lifting.take import root_kinds, root_paths
    from platypose.pipeline import lift_take, match_cameras, view_cameras

    sources = [Path(views)] if isinstance(views, (str, Path)) else [Path(v) for v in views]
    if not sources:
        raise InputError("lift: give at least one view (a video or keypoints)")
    try:
        sampler = replace(sampler or SamplerConfig(), **sampler_fields)
    except (TypeError, ValueError) as err:  # an unknown field, or a value SamplerConfig refuses
        raise InputError(f"sampler: {err}") from None
    windows = windows or WindowSettings()
    check_choice(sync)
    log = _Log(say)
    names = [view_name(s) for s in sources]
    what = ", ".join(map(str, sources))
    calibration = None if cams is None else _calibration(cams)
    cameras = None if calibration is None else match_cameras(calibration, names, what, _described(cams))
    standing = floor_for_lift(parse_floor(floor), None if calibration is None else calibration.meta)
    started = time.perf_counter()
    read = _ViewReader(detector, stride, threads, fps, image_size, log)
    tracks = [read(source) for source in sources]
    timings = {"keypoints_s": time.perf_counter() - started}
    sizes = [t.image_size for t in tracks]
    cameras = view_cameras(cameras, sizes, names, [str(s) for s in sources], what, log, "cams")
    synced = synchronise(
        sync, [t.keypoints for t in tracks], [t.frame_times for t in tracks], cameras, log, log.warning
    )
    cameras = synced.cameras
    keypoints, times, track_ids = take_keypoints(tracks, cameras, persons, what)
    log(f"{keypoints.shape[0]} view(s), {len(times)} frames, {len(track_ids)} person(s) (persons {persons})")
    given = None
    if root_trajectory is not None:
        from platypose.detectors.root_file import read_root_trajectory

        given = list(read_root_trajectory(Path(root_trajectory), times, keypoints.shape[2]))
    roots = root_paths(keypoints, times, cameras, root, given, say=log)
    bundle = prior if isinstance(prior, PriorBundle) else Prior.load(prior)
    started = time.perf_counter()
    result = lift_take(bundle, keypoints, times, track_ids, cameras, roots, sampler, windows, log=log, floor=standing)
    timings["lift_s"] = time.perf_counter() - started
    arguments = {
        "views": [str(v) for v in sources],
        "cams": _described(cams) if cams is not None else None,
        "persons": persons,
        "root": root,
        "root_trajectory": str(root_trajectory) if root_trajectory is not None else None,
        "floor": floor,
        "sync": dict(sync) if isinstance(sync, Mapping) else str(sync),
        "stride": stride,
        "sampler": asdict(sampler),
        "windows": asdict(windows),
    }
    return result.with_meta(
        version=__version__,
        input=what,
        arguments=arguments,
        sync=synced.record(),
        root=root_kinds(roots, given is not None),
        timings=timings,
        warnings=log.warnings,
    )


class _Log(JobLog):
    """A JobLog that also hands each line to ``say``."""

    def __init__(self, say: Callable[[str], None] | None) -> None:
        super().__init__()
        self.say = say

    def __call__(self, message: str) -> None:
        super().__call__(message)
        if self.say is not None:
            self.say(message)


def _calibration(cams: str | Path | Calibration | Sequence[Camera]) -> Calibration:
    """A Calibration from a file path, a Calibration, or cameras."""
    if isinstance(cams, Calibration):
        return cams
    if isinstance(cams, (str, Path)):
        from platypose.lifting.calibration import load_calibration

        return load_calibration(Path(cams))
    return Calibration(tuple(cams))


def _described(cams: object) -> str:
    """How an error names the calibration given."""
    return str(cams) if isinstance(cams, (str, Path)) else "the cameras given"


class _ViewReader:
    """The 2D tracks of one view: read when it holds keypoints, else detected (the detector loaded once)."""

    def __init__(self, detector, stride: int, threads: int | None, fps, image_size, log: JobLog) -> None:
        self.detector, self.stride, self.threads, self.log, self.model = detector, stride, threads, log, None
        self.fps, self.image_size = fps, image_size

    def __call__(self, source: Path):
        from platypose.detectors.sources import is_keypoint_source, read_keypoints

        started = time.perf_counter()
        if is_keypoint_source(source):
            tracks, how = read_keypoints(source, fps=self.fps, image_size=self.image_size), "read"
        else:
            from platypose.detectors.contracts import load_detector
            from platypose.detectors.pipeline import detect_video

            if not source.is_file():
                raise InputError(f"{source}: no such video or keypoint file")
            if self.model is None:
                self.model = load_detector(self.detector, threads=self.threads)
            tracks, how = detect_video(source, self.model, stride=self.stride), "detected"
        self.log(
            f"view {source.name}: {tracks.num_frames} frames, {tracks.num_persons} track(s), {how}, "
            f"{time.perf_counter() - started:.1f} s"
        )
        return tracks
