"""The in-memory calibration: cameras in a Z-up metre world plus a record of how they were obtained."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from platypose.lifting.camera import Camera


@dataclass(frozen=True)
class Calibration:
    """Cameras sharing one world frame, and ``meta`` saying where they came from and what was assumed.

    ``meta`` keys: ``format``, ``source``, ``world_up`` and ``units`` of the frame the cameras are in,
    ``assumptions`` (list of sentences) and ``conversions`` (list of sentences).
    """

    cameras: tuple[Camera, ...]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def names(self) -> tuple[str, ...]:
        """Camera names in file order."""
        return tuple(c.name for c in self.cameras)

    def camera(self, name: str) -> Camera:
        """The camera called ``name``; KeyError if there is none."""
        for cam in self.cameras:
            if cam.name == name:
                return cam
        raise KeyError(name)


def new_meta(fmt: str, source: str, world_up: str, units: str | float) -> dict[str, Any]:
    """A fresh ``meta`` dict for a calibration read from ``source`` in format ``fmt``."""
    return {"format": fmt, "source": source, "world_up": world_up, "units": units, "assumptions": [], "conversions": []}


def with_note(calibration: Calibration, key: str, sentence: str) -> Calibration:
    """A copy of ``calibration`` with ``sentence`` appended to ``meta[key]`` (``assumptions`` or ``conversions``)."""
    meta = dict(calibration.meta)
    meta[key] = [*meta.get(key, []), sentence]
    return replace(calibration, meta=meta)
