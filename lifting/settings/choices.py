"""The take's ``--floor`` and ``--sync`` choices read in pure Python, so that settings are checked before anything
heavy is imported (no numpy, torch or cv2): what they ask for takes effect later, in :mod:`platypose.lifting.floor`
(:func:`~platypose.lifting.floor.floor_for_lift`) and :mod:`platypose.lifting.sync.choice`."""

from __future__ import annotations

import math
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
