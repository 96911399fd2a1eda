"""The Python API: :func:`lift` one take, :func:`load_result` of an earlier lift, :class:`Prior` to load once.

``platypose.lift`` runs the pipeline of ``platypose lift`` (:func:`platypose.pipeline.run_take`) on one
take and returns the :class:`~platypose.exporters.result.LiftResult` in memory; nothing is
written. docs/api.md shows it end to end.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, replace
from pathlib import Path

from platypose.exporters.result import LiftResult
from platypose.lifting.calibration import Calibration
from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError
from platypose.lifting.job_log import JobLog
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.settings import DetectOptions, PriorSettings, SamplerConfig, TakeSettings, WindowSettings


class Prior:
    """Motion priors: ``Prior.load(...)`` gives a :class:`~platypose.lifting.prior.model.PriorBundle` to pass to
    :func:`lift` (load it once for many takes)."""

    @staticmethod
    def load(path: str | Path | None = None, device: str = "cpu", runtime: str = "auto") -> PriorBundle:
        """The prior at ``path`` (None: the shipped one) on ``device`` (cpu, cuda, auto), its network run by
        ``runtime`` (auto, float32, bfloat16, onnx)."""
        from platypose.lifting.prior.runtime import load_settings

        return load_settings(PriorSettings(path, device, runtime))


def load_result(path: str | Path) -> LiftResult:
    """The LiftResult of a ``.npz`` written by ``platypose lift`` (or by :func:`platypose.exporters.export`)."""
    from platypose.exporters.npz import read_npz

    return read_npz(_path("path", path))


def lift(
    views: str | Path | Sequence[str | Path],
    cams: str | Path | Calibration | Sequence[Camera] | None = None,
    *,
    prior: PriorBundle | str | Path | None = None,
    sampler: SamplerConfig | None = None,
    windows: WindowSettings | None = None,
    persons: str | int = "all",
    root: str = "auto",
    root_trajectory: str | Path | None = None,
    floor: str | Sequence[float] | None = "auto",
    sync: str | Path | Mapping[str, float] | None = "none",
    detector: str | Path | None = None,
    stride: int = 1,
    threads: int | None = None,
    fps: float | None = None,
    image_size: tuple[int, int] | None = None,
    say: Callable[[str], None] | None = None,
    **sampler_fields: object,
) -> LiftResult:
    """Lift the people of one take to 3D motion hypotheses, as ``platypose lift`` does for one input (both run
    :func:`platypose.pipeline.run_take`).

    ``views``: one path per camera, each a video (detected with ``detector``, default the
    bundled MoveNet) or precomputed keypoints (an OpenPose folder, our npz / CSV, MMPose
    JSON); its name (file stem, folder name without ``_json``) is matched to the camera's.
    ``cams``: a calibration file, a loaded :class:`Calibration` or a list of cameras; None
    for one view (a video's camera from its scene's lines and people, else a level camera at
    the origin, as ``lift`` without ``--cams``). ``prior``: a loaded
    :class:`Prior` (load it once for many takes) or a checkpoint path (None: the shipped
    prior). ``sampler`` / ``windows``: settings objects; keyword arguments named after
    :class:`SamplerConfig` fields (``samples=20, seed=1``) replace those fields.
    ``persons``: "all", "largest", "largest:N" or N as an int (the N largest), ids "id:0,2", a pixel "@X,Y"; ``root``: auto, triangulate or solve;
    ``root_trajectory``: a known pelvis path file. ``floor``: "auto" (the calibration's z = 0; without one,
    one camera: estimated under a quick lift, then grounded on), "z=H", "nx,ny,nz,d" or four numbers, "none" or
    None, as ``--floor``. ``sync``: how the views are put on one clock, as ``--sync``: "none" or None (the
    calibration's time offsets), "auto" (each view's offset estimated from its keypoints, logged with its
    confidence), an offsets JSON file, or a mapping ``{"cam01": 0.0, "cam02": 0.12}`` of seconds added to each
    view's frame times. ``stride``: detect every N-th frame (N >= 1); ``threads``: the detector's threads.
    ``fps`` and ``image_size`` (height, width): for keypoints without a video beside them (as ``--fps``,
    ``--image-size``). ``say`` receives the log's lines.

    Returns the LiftResult (hypotheses (P, N, T, 17, 3) world metres, median, 2D keypoints,
    cameras with their time offsets, ``meta`` with the arguments, the settings, the offsets used
    (``meta["sync"]``) and the log's warnings, a truncated video's among them); InputError naming the argument
    for a bad one, and for bad input, as the CLI.
    """
    from platypose.detectors.sources.keypoint_source import view_name
    from platypose.detectors.view_reader import ViewReader
    from platypose.pipeline import run_take

    sources = _sources(views)
    take = TakeSettings(
        persons=persons,
        root=root,
        root_trajectory=_path("root_trajectory", root_trajectory, optional=True),
        floor=floor,
        sync=sync,
        sampler=_sampler(sampler, sampler_fields),
        windows=_instance("windows", windows, WindowSettings) or WindowSettings(),
    )
    detect = DetectOptions(detector=detector, stride=stride, threads=threads, fps=fps, image_size=image_size)
    if say is not None and not callable(say):
        raise InputError(f"say must be a function taking a line of text, got {say!r}", option="say")
    load_prior = _prior_loader(prior)
    calibration = _calibration(cams)
    arguments = {
        "views": [str(v) for v in sources],
        "cams": _described(cams) if cams is not None else None,
        "persons": take.persons,
        "root": take.root,
        "root_trajectory": str(take.root_trajectory) if take.root_trajectory is not None else None,
        "floor": take.floor,
        "sync": dict(take.sync) if isinstance(take.sync, Mapping) else str(take.sync),
        "stride": detect.stride,
        "sampler": asdict(take.sampler),
        "windows": asdict(take.windows),
    }
    return run_take(
        views=[(view_name(s), s) for s in sources],
        calibration=calibration,
        settings=take,
        read=ViewReader(detect),
        prior=load_prior,
        log=_Log(say),
        what=", ".join(map(str, sources)),
        described=_described(cams),
        arguments=arguments,
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


def _prior_loader(prior: object) -> Callable[[], PriorBundle]:
    """The prior to lift with, loaded when the pipeline asks for it (once the inputs are read and checked)."""
    if isinstance(prior, PriorBundle):
        return lambda: prior
    path = _path("prior", prior, optional=True)
    return lambda: Prior.load(path)


def _calibration(cams: object) -> Calibration | None:
    """A Calibration from a file path, a Calibration, or cameras; None for None."""
    if cams is None or isinstance(cams, Calibration):
        return cams
    if isinstance(cams, (str, os.PathLike)):
        from platypose.lifting.calibration import load_calibration

        return load_calibration(Path(cams))
    if isinstance(cams, Sequence) and cams and all(isinstance(c, Camera) for c in cams):
        return Calibration(tuple(cams))
    raise InputError(
        f"cams must be a calibration file, a Calibration or a list of cameras, got {cams!r}", option="cams"
    )


def _described(cams: object) -> str:
    """How an error names the calibration given."""
    return str(cams) if isinstance(cams, (str, os.PathLike)) else "the cameras given"


def _sources(views: object) -> list[Path]:
    """The views' paths: one path, or a sequence of them; InputError naming ``views`` otherwise."""
    if isinstance(views, (str, os.PathLike)):
        return [Path(views)]
    if isinstance(views, Sequence) and views and all(isinstance(v, (str, os.PathLike)) for v in views):
        return [Path(v) for v in views]
    if isinstance(views, Sequence) and not views:
        raise InputError("views: give at least one view (a video or keypoints)", option="views")
    raise InputError(f"views must be a path or a list of paths (videos or keypoints), got {views!r}", option="views")


def _path(name: str, value: object, optional: bool = False) -> Path | None:
    """``value`` as a path; None when ``optional``; InputError naming ``name`` otherwise."""
    if value is None and optional:
        return None
    if isinstance(value, (str, os.PathLike)) and str(value):
        return Path(value)
    raise InputError(f"{name} must be a path, got {value!r}", option=name)


def _instance(name: str, value: object, cls: type):
    """``value`` if it is None or a ``cls``; InputError naming ``name`` otherwise."""
    if value is None or isinstance(value, cls):
        return value
    raise InputError(f"{name} must be a {cls.__name__}, got {value!r}", option=name)


def _sampler(sampler: object, fields: dict[str, object]) -> SamplerConfig:
    """``sampler`` (default: SamplerConfig()) with ``fields`` replaced; InputError naming an unknown field."""
    base = _instance("sampler", sampler, SamplerConfig) or SamplerConfig()
    known = {f.name for f in dataclasses.fields(SamplerConfig)}
    unknown = sorted(set(fields) - known)
    if unknown:
        raise InputError(
            f"lift: unknown argument(s) {', '.join(unknown)} (not a SamplerConfig field)", option=unknown[0]
        )
    return replace(base, **fields)
