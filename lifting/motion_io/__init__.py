"""Load real 3D human motion from mocap files onto our 17-joint skeleton (metres, Z up, with frame rate).

``load_motion(path)`` picks the reader by extension (and content where an
extension is shared), fills each clip's source and licence from the nearest
``SOURCE.json``, and raises :class:`lifting.errors.InputError` with a one-line
message for a broken or unknown file, or a clip with infinite or implausible
values (:mod:`lifting.motion_io.checks`). ``load_motion_paths`` expands folders.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

from platypose.lifting.errors import InputError
from platypose.lifting.motion import Motion
from platypose.lifting.motion_io.asf_amc import load_amc
from platypose.lifting.motion_io.bvh import load_bvh
from platypose.lifting.motion_io.c3d import load_c3d
from platypose.lifting.motion_io.checks import check_motion
from platypose.lifting.motion_io.cmu_expmap import is_cmu_expmap, load_cmu_expmap
from platypose.lifting.motion_io.deepmimic import is_deepmimic, load_deepmimic
from platypose.lifting.motion_io.h36m import is_h36m_npz, load_h36m
from platypose.lifting.motion_io.holosoma import load_holosoma
from platypose.lifting.motion_io.plain_npz import is_plain_npz, load_plain_npz
from platypose.lifting.motion_io.provenance import find_provenance

Loader = Callable[..., list[Motion]]


@dataclasses.dataclass(frozen=True)
class MotionFormat:
    """One readable format: name, file extensions, one-line description, loader, and a content check.

    ``claims(path)`` says whether a file with one of the extensions is of this
    format (several formats share ``.npz``; ``.txt``/``.json`` may be licences);
    ``options`` are the keyword options its loader takes besides ``fps``.
    """

    name: str
    extensions: tuple[str, ...]
    description: str
    load: Loader
    claims: Callable[[Path], bool] = lambda path: True
    options: tuple[str, ...] = ()


FORMATS: tuple[MotionFormat, ...] = (
    MotionFormat(
        "bvh",
        (".bvh",),
        "BVH of any hierarchy (known namings or a name map), units detected, Y up",
        load_bvh,
        options=("name_map", "scale"),
    ),
    MotionFormat(
        "asf_amc",
        (".amc",),
        "Acclaim/CMU AMC motion with its .asf skeleton beside it, 120 fps by default",
        load_amc,
        options=("asf",),
    ),
    MotionFormat("holosoma", (".npy",), "holosoma-retargeting (T, 53, 3) positions, 120 fps default", load_holosoma),
    MotionFormat(
        "h36m",
        (".npz",),
        "Human3.6M VideoPose3D data_3d_h36m.npz (positions_3d), a clip per subject/action, 50 fps",
        load_h36m,
        is_h36m_npz,
    ),
    MotionFormat(
        "plain_npz",
        (".npz",),
        "npz with joints (T, 17, 3) metres Z up, fps, optional joint_names",
        load_plain_npz,
        is_plain_npz,
    ),
    MotionFormat("c3d", (".c3d",), "C3D marker trial (joint centres it defines; the rest NaN, listed)", load_c3d),
    MotionFormat(
        "cmu_expmap",
        (".txt",),
        "CMU mocap as exponential maps (117 comma-separated values a frame), 120 fps by default",
        load_cmu_expmap,
        is_cmu_expmap,
    ),
    MotionFormat(
        "deepmimic",
        (".txt", ".json"),
        "DeepMimic humanoid clip (JSON Frames) with humanoid.urdf beside it",
        load_deepmimic,
        is_deepmimic,
        options=("urdf", "scale"),
    ),
)

# Companion files that belong to a clip but hold no motion themselves.
COMPANIONS: dict[str, str] = {
    ".asf": "an ASF skeleton; load its .amc motion",
    ".urdf": "a robot model; load the clips beside it",
}

# Extensions also used by non-motion files (licences, SOURCE.json): such files
# are skipped unless a format claims them by content.
GENERIC_EXTENSIONS: frozenset[str] = frozenset({".txt", ".json"})


def supported_formats() -> str:
    """One line per format, for help texts."""
    return "\n".join(f"{f.name}: {', '.join(f.extensions)} - {f.description}" for f in FORMATS)


def _format_of(path: Path) -> MotionFormat | None:
    """The format of a file, None for a file of no motion format; InputError if it looks like one but is not."""
    candidates = [f for f in FORMATS if path.suffix.lower() in f.extensions]
    for fmt in candidates:
        if fmt.claims(path):
            return fmt
    if candidates and path.suffix.lower() not in GENERIC_EXTENSIONS:
        raise InputError(f"{path}: not a valid {' or '.join(f.name for f in candidates)} file")
    return None


def load_motion(
    path: str | Path, fps: float | None = None, name_map: Mapping[str, str] | None = None, **options
) -> list[Motion]:
    """All clips in one motion file, with source and licence filled; ``fps`` overrides a file's rate.

    ``name_map`` maps our joint names to a BVH file's joint names; ``options`` go to
    the format's loader (``scale`` for BVH and DeepMimic, ``urdf`` for DeepMimic, ``asf`` for AMC).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    fmt = _format_of(path)
    if fmt is None and path.suffix.lower() in COMPANIONS:
        raise InputError(f"{path}: this is {COMPANIONS[path.suffix.lower()]}")
    if fmt is None:
        known = sorted({e for f in FORMATS for e in f.extensions})
        raise InputError(f"{path}: unknown motion format '{path.suffix}'; supported: {', '.join(known)}")
    if fps is not None and not fps > 0:
        raise InputError(f"{path}: frame rate must be positive, got {fps}")
    kwargs = {k: v for k, v in {**options, "name_map": name_map}.items() if v is not None}
    unsupported = sorted(set(kwargs) - set(fmt.options))
    if unsupported:
        raise InputError(f"{path}: option(s) {', '.join(unsupported)} do not apply to {fmt.name} files")
    try:
        clips = fmt.load(path, fps=fps, **kwargs)
    except InputError:
        raise
    except (ValueError, KeyError, IndexError, TypeError, OSError, EOFError) as err:
        raise InputError(f"{path}: cannot read as {fmt.name}: {type(err).__name__}: {err}".replace("\n", " ")) from None
    for clip in clips:
        check_motion(clip, str(path))
    source, licence = find_provenance(path)
    return [dataclasses.replace(c, source=source, licence=licence) for c in clips]


def motion_files(paths: Iterable[str | Path]) -> list[Path]:
    """The files ``paths`` name: each file as given, each folder's motion files (recursively, sorted)."""
    files: list[Path] = []
    for item in map(Path, paths):
        if item.is_dir():
            files.extend(sorted(p for p in item.rglob("*") if p.is_file() and _format_of(p)))
        elif item.is_file() or not item.exists():
            files.append(item)
        else:
            raise InputError(f"{item}: not a file or folder")
    return files


def load_motion_paths(paths: Iterable[str | Path], fps: float | None = None, **options) -> list[Motion]:
    """Clips of all files and folders (recursively, sorted), skipping files of no motion format.

    ``options`` (``name_map``, ``scale``, ...) go to the files whose format takes them.
    """
    clips: list[Motion] = []
    for file in motion_files(paths):
        fmt = _format_of(file) if file.is_file() else None
        taken = {k: v for k, v in options.items() if fmt is not None and k in fmt.options}
        clips.extend(load_motion(file, fps=fps, **taken))
    return clips
