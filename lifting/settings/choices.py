"""The take's ``--persons``, ``--floor`` and ``--sync`` choices read in pure Python, so that settings are checked
before anything heavy is imported (no numpy, torch or cv2): what they ask for takes effect later, in
:mod:`platypose.detectors.persons.person_choice` (the tracks picked), :mod:`platypose.lifting.floor`
(:func:`~platypose.lifting.floor.floor_for_lift`) and :mod:`platypose.lifting.sync.choice`.

Numbers of ``--persons`` are ASCII digits only (``str.isdigit`` takes ``²``)."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from platypose.lifting.errors import InputError

MAX_FLOOR_TILT_DEG = 45.0  # a given floor steeper than this is a wall or upside down
MIN_UP_COSINE = math.cos(math.radians(MAX_FLOOR_TILT_DEG))
MAX_FLOOR_DISTANCE_M = 1000.0
FLOOR_SPECS = "auto, none, z=H (a height) or nx,ny,nz,d (a plane n.x + d = 0, n up)"
SyncChoice = str | Path | Mapping[str, float]


@dataclass(frozen=True)
class GivenPlane:
    """A floor plane as the user gave it: ``nx, ny, nz, d`` of ``n . x + d = 0`` (``n`` not yet of unit length),
    checked to be finite, pointing up and near the origin (:func:`read_floor`)."""

    nx: float
    ny: float
    nz: float
    d: float


FloorChoice = GivenPlane | str | None  # a plane, "auto", or None (no floor)


def check_plane(nx: float, ny: float, nz: float, d: float) -> None:
    """ValueError unless ``n . x + d = 0`` has a finite non-zero normal ``n``."""
    length = math.sqrt(nx * nx + ny * ny + nz * nz)
    if not math.isfinite(length) or length < 1e-9 or not math.isfinite(d):
        raise ValueError(f"floor plane {nx},{ny},{nz},{d}: the normal must be finite and non-zero")


def read_floor(text: str) -> FloorChoice:
    """A floor specification: "auto" (returned as is), "none" (None), "z=H" or "nx,ny,nz,d" (a :class:`GivenPlane`);
    InputError naming the option otherwise, and for a plane that is not a floor (steeper than
    ``MAX_FLOOR_TILT_DEG``, or farther than ``MAX_FLOOR_DISTANCE_M`` from the origin)."""
    spec = text.strip().lower()
    if spec in ("auto", "none"):
        return None if spec == "none" else "auto"
    try:
        values = [0.0, 0.0, 1.0, -float(spec[2:])] if spec.startswith("z=") else [float(v) for v in spec.split(",")]
        if len(values) == 4:
            check_plane(*values)
            nx, ny, nz, d = values
            length = math.sqrt(nx * nx + ny * ny + nz * nz)
            if nz / length < MIN_UP_COSINE or not abs(d / length) <= MAX_FLOOR_DISTANCE_M:
                raise ValueError(
                    f"a floor's normal points up (within {MAX_FLOOR_TILT_DEG:g} degrees of +z, the world's up) "
                    f"and it lies within {MAX_FLOOR_DISTANCE_M:g} m of the origin"
                )
            return GivenPlane(*values)
    except ValueError as err:
        raise InputError(f"floor {text!r}: {err}; use {FLOOR_SPECS}", option="floor") from None
    raise InputError(f"floor {text!r}: not understood; use {FLOOR_SPECS}", option="floor")


def check_sync(choice: SyncChoice) -> None:
    """InputError unless ``choice`` is auto, none, an existing offsets file or a mapping of names to seconds."""
    if isinstance(choice, Mapping) or choice in ("auto", "none"):
        return
    if not Path(choice).is_file():
        raise InputError(f"{choice}: offsets file not found (sync takes auto, none or an offsets .json)")


PERSONS_CHOICES = (
    "'all', 'largest', 'largest:N' (the N largest), ids such as id:0,2 or 0,2 (one id: id:2 or 2,) or a pixel @X,Y"
)
_NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?", re.ASCII)


def _whole(text: str) -> int:
    """A whole number written in ASCII digits; ValueError otherwise (``int`` takes ``'٣'`` and ``'1_0'``)."""
    text = text.strip()
    if not (text.isascii() and text.isdigit()):
        raise ValueError(text)
    return int(text)


def _pixel(text: str) -> float:
    """A finite number written in ASCII (``float`` takes other scripts' digits, ``'1_0'`` and ``'inf'``)."""
    text = text.strip()
    if not _NUMBER.fullmatch(text):
        raise ValueError(text)
    return float(text)


def parse_persons(text: str) -> tuple[str, object]:
    """``("all", None)``, ``("count", N)`` (largest: 1), ``("ids", [id, ...])`` or ``("point", (x, y))``;
    InputError naming the option otherwise, and for a plain number (a count or an id: it says both)."""
    spec = text.strip()
    if spec == "all":
        return "all", None
    if spec == "largest":
        return "count", 1
    if spec.isascii() and spec.isdigit():
        raise InputError(
            f"persons {spec}: a plain number is ambiguous; write largest:{spec} for the {spec} largest person(s) "
            f"or id:{spec} for the track p{spec}",
            option="persons",
        )
    try:
        if spec.startswith("largest:"):
            count = _whole(spec.removeprefix("largest:"))
            if count > 0:
                return "count", count
        elif spec.startswith("@"):
            x, y = (_pixel(v) for v in spec[1:].split(","))
            if math.isfinite(x) and math.isfinite(y):
                return "point", (x, y)
        elif spec.startswith("id:") or "," in spec:
            ids = [_whole(v) for v in spec.removeprefix("id:").split(",") if v.strip()]
            if ids:
                return "ids", sorted(set(ids))
    except ValueError:
        pass
    raise InputError(f"persons must be {PERSONS_CHOICES}, got {text!r}", option="persons")
