"""A split lift's piece file read back and checked before use: the arrays its ``.npy`` headers claim (before
anything is loaded), then their values. A piece that fails is not used: :class:`platypose.cli.runs.split.SplitLifter`
removes it and lifts it again."""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path

import numpy as np

from platypose.exporters.npz_checks import MAX_COORDINATE_M
from platypose.lifting.files.npz_limits import npz_headers

UNREADABLE = (zipfile.BadZipFile, EOFError, OSError, zlib.error, KeyError)


def read_lift_piece(path: Path, present: np.ndarray, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """The (hypotheses (p, N, t, 17, 3), energy (p, N, t)) of the piece file ``path`` whose persons are present
    (``present``, (p, t)) in the frames it lifted, ``samples`` (N) hypotheses each; ValueError saying what is wrong
    when its headers claim other arrays (checked before loading), it cannot be read, or its values are not finite
    where a person is present or lie beyond ``MAX_COORDINATE_M`` of the origin."""
    p, t = present.shape
    expected = {
        "hypotheses": ((p, samples, t, 17, 3), np.dtype(np.float32)),
        "energy": ((p, samples, t), np.dtype(np.float32)),
    }
    try:
        claimed = npz_headers(path)
        if claimed != expected:
            raise ValueError(f"arrays {_shapes(claimed)} where {_shapes(expected)} were expected")
        with np.load(path, allow_pickle=False) as data:
            hypotheses, energy = data["hypotheses"], data["energy"]
    except UNREADABLE as err:
        raise ValueError(f"not a readable npz ({type(err).__name__}: {' '.join(str(err).split())})") from None
    check_piece_values(hypotheses, energy, present)
    return hypotheses, energy


def _shapes(arrays: dict) -> str:
    return ", ".join(f"{name} {tuple(shape)} {dtype}" for name, (shape, dtype) in sorted(arrays.items())) or "none"


def check_piece_values(hypotheses: np.ndarray, energy: np.ndarray, present: np.ndarray) -> None:
    """ValueError unless ``hypotheses`` (p, N, t, 17, 3, metres) and ``energy`` (p, N, t) are finite wherever
    ``present`` (p, t) and every coordinate lies within ``MAX_COORDINATE_M`` of the origin."""
    seen = np.broadcast_to(present[:, None], energy.shape)
    if not np.isfinite(hypotheses[seen]).all() or not np.isfinite(energy[seen]).all():
        raise ValueError("values that are not finite in frames where a person is present")
    with np.errstate(invalid="ignore"):
        far = float(np.nanmax(np.abs(hypotheses), initial=0.0))
    if far > MAX_COORDINATE_M:
        raise ValueError(f"coordinates {far:.3g} m from the origin (over {MAX_COORDINATE_M:g} m)")
