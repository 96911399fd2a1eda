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
from platypose.exporters.opensim_model import (
    HINGE_COORDINATES,
    HINGE_RANGE_DEG,
    MARKERS,
    build_model,
    ik_tool,
    scale_tool,
)
from platypose.exporters.result import LiftResult
from platypose.exporters.trc import write_trc
from platypose.lifting.anatomy.hinges import signed_flexion
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import atomic_path

FULL_BYTES = 4 * 2**20  # free space under which a failure of OpenSim's file writes counts as a full disk

AT_LIMIT_DEG = 1.0  # a hinge this close to an end of its range is pinned there
AT_LIMIT_SHARE = 0.05  # ... warned of when more than this share of frames are
LARGE_RMS_M = 0.03  # median marker RMS warned of: the model could not follow the joints
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
    """How one person's IK went: the median and largest per-frame marker RMS (m), each body's scale factor, and
    per hinge coordinate the share of frames IK left within ``AT_LIMIT_DEG`` of an end of its range."""

    rms_median_m: float
    rms_max_m: float
    scales: dict[str, float]
    at_limit: dict[str, float]

    def warnings(self) -> list[str]:
        """What the fit says is wrong: hinges pinned at a limit in over ``AT_LIMIT_SHARE`` of the frames, a median
        marker RMS over ``LARGE_RMS_M``; empty when neither."""
        pinned = [f"{name} {share:.0%}" for name, share in self.at_limit.items() if share > AT_LIMIT_SHARE]
        out = [f"hinge at its limit in over {AT_LIMIT_SHARE:.0%} of frames ({', '.join(pinned)})"] if pinned else []
        if self.rms_median_m > LARGE_RMS_M:
            out.append(f"marker RMS {100 * self.rms_median_m:.1f} cm (over {100 * LARGE_RMS_M:.0f})")
        return out

    def as_dict(self) -> dict:
        """JSON-ready form for ``meta``."""
        return {
            "marker_rms_median_m": self.rms_median_m,
            "marker_rms_max_m": self.rms_max_m,
            "scales": self.scales,
            "hinge_at_limit_share": self.at_limit,
            "warnings": self.warnings(),
        }


def read_storage(path: Path | str) -> tuple[list[str], np.ndarray]:
    """Column names and values (rows, columns) of an OpenSim ``.mot`` / ``.sto`` text file."""
    lines = Path(path).read_text().splitlines()
    end = next(k for k, line in enumerate(lines) if line.strip().lower() == "endheader")
    names = lines[end + 1].split("\t")
    return [n.strip() for n in names], np.array(
        [[float(v) for v in line.split()] for line in lines[end + 2 :] if line.strip()]
    )


def at_limit_shares(names: list[str], values: np.ndarray) -> dict[str, float]:
    """Per hinge coordinate of a ``.mot``'s columns ``names`` and rows ``values`` (degrees), the share of rows within
    ``AT_LIMIT_DEG`` of an end of ``HINGE_RANGE_DEG``."""
    low, high = HINGE_RANGE_DEG
    out = {}
    for name in HINGE_COORDINATES:
        column = values[:, names.index(name)]
        out[name] = round(float(np.mean((column < low + AT_LIMIT_DEG) | (column > high - AT_LIMIT_DEG))), 3)
    return out


def write_hinge_hints(joints: np.ndarray, frame_times: np.ndarray, path: Path) -> Path:
    """An OpenSim storage at ``path`` of the signed flexion (:func:`lifting.anatomy.hinges.signed_flexion`, degrees) of
    filled joints (T, 17, 3) per frame, as the :data:`HINGE_COORDINATES` IK is hinted with."""
    flexion = np.clip(signed_flexion(joints), *HINGE_RANGE_DEG)
    table = np.concatenate([np.asarray(frame_times, np.float64)[:, None], flexion], axis=1)
    header = f"hinges\nversion=1\nnRows={len(table)}\nnColumns={table.shape[1]}\ninDegrees=yes\nendheader\n"
    with path.open("w", encoding="ascii", newline="\n") as f:
        f.write(header + "\t".join(("time", *HINGE_COORDINATES)) + "\n")
        np.savetxt(f, table, fmt="%.6f", delimiter="\t")
    return path


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
    hints = write_hinge_hints(joints, frame_times, work / "hinges.sto")
    tool = ik_tool(osim, str(trc), times, str(work / "ik.mot"), str(hints))
    tool.setResultsDir(str(work))
    tool.setModel(scaled)
    if not tool.run():
        raise RuntimeError(f"OpenSim's inverse kinematics failed on {trc}")
    names, errors = read_storage(next(work.glob("*_ik_marker_errors.sto")))
    rms = errors[:, names.index("marker_error_RMS")]
    at_limit = at_limit_shares(*read_storage(work / "ik.mot"))
    return IkFit(float(np.median(rms)), float(rms.max()), _scales(scaled), at_limit)


def flag_ik(reports: list[dict], fits: dict[str, dict], track_ids: np.ndarray) -> list[dict]:
    """Plausibility ``reports`` (``meta["plausibility"]``, one per person) with the flag ``"opensim ik"`` and its
    ``opensim_ik_warnings`` added where a person's fit (``fits``, by ``p<track>``) warns, ``flag_text`` redone."""
    from platypose.lifting.checks.flags import flag_text

    out = []
    for track, report in zip(track_ids, reports):
        warnings = fits.get(f"p{int(track)}", {}).get("warnings", [])
        if warnings and "opensim ik" not in report.get("flags", []):
            report = {**report, "flags": [*report.get("flags", []), "opensim ik"], "opensim_ik_warnings": warnings}
            report["flag_text"] = flag_text(report)
        out.append(report)
    return out


def write_mots(
    result: LiftResult,
    out_dir: Path,
    name: str,
    say: Callable[[str], None] = lambda _: None,
    warn: Callable[[str], None] = lambda _: None,
) -> tuple[list[Path], dict[str, dict]]:
    """``<name>_p<k>.mot`` and ``<name>_p<k>.osim`` per person seen, atomically, and each person's :class:`IkFit`;
    progress to ``say``, each fit's warnings to ``warn`` (``person <k> OpenSim IK: <warning>``)."""
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
        for warning in fit.warnings():
            warn(f"person {track} OpenSim IK: {warning}")
    return paths, fits
