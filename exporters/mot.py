"""OpenSim joint angles: the ``platypose17`` model scaled to each person and fitted by OpenSim's IK.

Per person with a present frame: the median motion (gaps filled, :mod:`exporters.gaps`)
is written as a TRC in a temporary folder, the generic model
(:func:`exporters.opensim_model.build_model`) is scaled on it and inverse kinematics
run over the whole clip; ``<name>_p<k>.mot`` (the model's coordinates in degrees and
metres, OpenSim's storage format) and the scaled model ``<name>_p<k>.osim`` are moved
into the output folder. Needs the ``opensim`` package (``pip install 'platypose[opensim]'``).

OpenSim prints each model's summary on standard output itself (C++, past its logger): that output is sent to
``/dev/null`` while it works, so ``export`` prints only the files written and ``-q`` is quiet. When OpenSim fails on
a full temporary disk (it reports only "SimTK Exception ... Xml.cpp"), the error is that disk's, in one line.
"""

from __future__ import annotations

import errno
import os
import shutil
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from platypose.exporters.frames import Lead
from platypose.exporters.gaps import fill_frames, fill_plan
from platypose.exporters.markers import read_frames
from platypose.exporters.opensim_model import MARKERS, build_model, ik_tool, scale_tool
from platypose.exporters.result import LiftResult
from platypose.exporters.trc import write_trc
from platypose.lifting.atomic import atomic_path
from platypose.lifting.errors import InputError

FULL_BYTES = 4 * 2**20  # free space under which a failure of OpenSim's file writes counts as a full disk
MISSING = "formats: mot needs the opensim package; install it with pip install 'platypose[opensim]'"


def load_opensim() -> Any:
    """The ``opensim`` module with its log quiet (errors only, no ``opensim.log``); InputError if it is missing."""
    try:
        import opensim
    except ImportError as err:
        raise InputError(MISSING, option="formats") from err
    opensim.Logger.setLevelString("error")
    opensim.Logger.removeFileSink()
    return opensim


@contextmanager
def native_stdout_quiet() -> Iterator[None]:
    """Standard output (file descriptor 1, which OpenSim's C++ code writes to) goes to /dev/null in the block."""
    sys.stdout.flush()
    saved = os.dup(1)
    quiet = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(quiet, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(quiet)


@contextmanager
def full_disk_as_os_error(work: Path) -> Iterator[None]:
    """OpenSim's failure to write in ``work`` (a RuntimeError) raised as OSError ENOSPC when that disk is full."""
    try:
        yield
    except (RuntimeError, OSError) as err:
        try:
            full = shutil.disk_usage(work).free < FULL_BYTES
        except OSError:
            full = False
        if full:
            raise OSError(errno.ENOSPC, "no space left for OpenSim's temporary files (set TMPDIR)", str(work)) from err
        raise


@dataclass(frozen=True)
class IkFit:
    """How one person's IK went: the median and largest per-frame marker RMS (m), and each body's scale factor."""

    rms_median_m: float
    rms_max_m: float
    scales: dict[str, float]

    def as_dict(self) -> dict:
        """JSON-ready form for ``meta``."""
        return {"marker_rms_median_m": self.rms_median_m, "marker_rms_max_m": self.rms_max_m, "scales": self.scales}


def read_storage(path: Path | str) -> tuple[list[str], np.ndarray]:
    """Column names and values (rows, columns) of an OpenSim ``.mot`` / ``.sto`` text file."""
    lines = Path(path).read_text().splitlines()
    end = next(k for k, line in enumerate(lines) if line.strip().lower() == "endheader")
    names = lines[end + 1].split("\t")
    return [n.strip() for n in names], np.array(
        [[float(v) for v in line.split()] for line in lines[end + 2 :] if line.strip()]
    )


def _scales(scaled: Any) -> dict[str, float]:
    """The scale factor of each body with a marker off its origin: that marker's distance from the origin in the
    scaled model over the generic model's."""
    out = {}
    for name, (body, location) in MARKERS.items():
        if any(location):
            scaled_at = scaled.getMarkerSet().get(name).get_location()
            out[body] = float(np.linalg.norm([scaled_at[k] for k in range(3)]) / np.linalg.norm(location))
    return out


def person_mot(osim: Any, joints: np.ndarray, frame_times: np.ndarray, fps: float, work: Path) -> IkFit:
    """Scale the model and run IK on filled world joints (T, 17, 3) in folder ``work``; ``work/ik.mot`` and
    ``work/scaled.osim`` are written there."""
    trc = write_trc(joints, frame_times, fps, work / "markers.trc")
    times = (float(frame_times[0]), float(frame_times[-1]))
    build_model(osim).printToXML(str(work / "generic.osim"))
    scale_tool(osim, str(work / "generic.osim"), str(trc), times, str(work / "scaled.osim")).run()
    if not (work / "scaled.osim").exists():
        raise RuntimeError(f"OpenSim's scaling wrote no model in {work}")
    scaled = osim.Model(str(work / "scaled.osim"))
    tool = ik_tool(osim, str(trc), times, str(work / "ik.mot"))
    tool.setResultsDir(str(work))
    tool.setModel(scaled)
    if not tool.run():
        raise RuntimeError(f"OpenSim's inverse kinematics failed on {trc}")
    names, errors = read_storage(next(work.glob("*_ik_marker_errors.sto")))
    rms = errors[:, names.index("marker_error_RMS")]
    return IkFit(float(np.median(rms)), float(rms.max()), _scales(scaled))


def write_mots(
    result: LiftResult, out_dir: Path, name: str, say: Callable[[str], None] = lambda _: None
) -> tuple[list[Path], dict[str, dict]]:
    """``<name>_p<k>.mot`` and ``<name>_p<k>.osim`` per person seen, atomically, and each person's :class:`IkFit`."""
    osim = load_opensim()
    paths: list[Path] = []
    fits: dict[str, dict] = {}
    present = result.present()
    for p, track in enumerate(result.track_ids):
        if not present[p].any():
            continue
        joints = read_frames(Lead(result.median, p))
        filled = fill_frames(joints, fill_plan(present[p], result.frame_times), slice(None))
        with tempfile.TemporaryDirectory(prefix="platypose-opensim-") as folder:
            work = Path(folder)
            with full_disk_as_os_error(work), native_stdout_quiet():
                fit = person_mot(osim, filled, np.asarray(result.frame_times), result.fps, work)
            for suffix, produced in ((".mot", "ik.mot"), (".osim", "scaled.osim")):
                target = out_dir / f"{name}_p{track}{suffix}"
                with atomic_path(target) as tmp:
                    shutil.copyfile(work / produced, tmp)
                paths.append(target)
        fits[f"p{track}"] = fit.as_dict()
        say(f"{name}: person {track} OpenSim IK: marker RMS {100 * fit.rms_median_m:.1f} cm (median)")
    return paths, fits
