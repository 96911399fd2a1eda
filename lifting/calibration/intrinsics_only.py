"""Intrinsics-only text: one camera per line, ``[name] fx fy cx cy [width height]``; ``#`` starts a comment.

A line without a name takes the file's stem (one line) or ``cam<line number>``. Without width and
height the image is assumed to be twice the principal point. There are no extrinsics: each camera
sits level at the world origin (see :mod:`lifting.calibration.defaults`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.lifting.calibration.defaults import SIZE_FROM_CENTRE_NOTE, complete_camera, size_from_principal_point
from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.calibration.validate import as_size, check_cameras, check_intrinsics, read_calibration_bytes
from platypose.lifting.errors import InputError


def _is_number(token: str) -> bool:
    """True when ``token`` parses as a float."""
    try:
        float(token)
    except ValueError:
        return False
    return True


def parse_line(line: str, source: str) -> tuple[str | None, np.ndarray, tuple[int, int] | None]:
    """Name (or None), K (3, 3) and (height, width) (or None) from one ``[name] fx fy cx cy [w h]`` line."""
    tokens = line.replace(",", " ").split()
    name = None if _is_number(tokens[0]) else tokens.pop(0)
    if len(tokens) not in (4, 6) or not all(_is_number(t) for t in tokens):
        raise InputError(f"{source}: expected '[name] fx fy cx cy [width height]', got {line.strip()!r}")
    fx, fy, cx, cy = (float(t) for t in tokens[:4])
    K = check_intrinsics([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], source, f"intrinsics {line.strip()!r}")
    size = as_size([tokens[5], tokens[4]], source, "width height") if len(tokens) == 6 else None
    return name, K, size


def read_intrinsics(path: Path) -> Calibration:
    """Read an intrinsics-only text file."""
    source = str(path)
    try:
        text = read_calibration_bytes(path).decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{source}: not a text file") from None
    lines = [ln.split("#", 1)[0] for ln in text.splitlines()]
    lines = [ln for ln in lines if ln.strip()]
    meta = new_meta("intrinsics-txt", source, "z", "m")
    cameras = []
    for number, line in enumerate(lines, start=1):
        name, K, size = parse_line(line, source)
        name = name or (path.stem if len(lines) == 1 else f"cam{number}")
        if size is None:
            size = size_from_principal_point(K)
            meta["assumptions"].append(f"camera {name}: {SIZE_FROM_CENTRE_NOTE}")
        camera, notes = complete_camera(name, size, K, None, None, None)
        cameras.append(camera)
        meta["assumptions"].extend(notes)
    return Calibration(cameras=check_cameras(cameras, source), meta=meta)
