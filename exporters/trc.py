"""TRC marker files (OpenSim, Pose2Sim): one per person, metres, Y up, no NaN (gaps filled, see markers)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.exporters.markers import MARKER_NAMES, to_opensim_axes
from platypose.lifting.files.atomic import atomic_open


def trc_text_header(file_name: str, fps: float, num_frames: int) -> str:
    """The five header lines of a TRC file as Pose2Sim writes them (tab separated)."""
    rate = f"{fps:g}"
    names = "\t".join(f"{n}\t\t" for n in MARKER_NAMES)
    axes = "\t".join(f"X{i}\tY{i}\tZ{i}" for i in range(1, len(MARKER_NAMES) + 1))
    return (
        f"PathFileType\t4\t(X/Y/Z)\t{file_name}\n"
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames\n"
        f"{rate}\t{rate}\t{num_frames}\t{len(MARKER_NAMES)}\tm\t{rate}\t0\t{num_frames}\n"
        f"Frame#\tTime\t{names}\n"
        f"\t\t{axes}\n"
    )


def write_trc(joints: np.ndarray, frame_times: np.ndarray, fps: float, path: Path | str) -> Path:
    """Write filled world joints (T, 17, 3) metres (Z up, no NaN) as a TRC file at ``path`` atomically.

    ``Frame#`` is the output frame index (0 first, as in our CSV), ``Time`` the frame's time in seconds.
    """
    path = Path(path)
    if not np.isfinite(joints).all():
        raise ValueError(f"{path}: TRC needs filled joints (no NaN)")
    T = len(joints)
    table = np.concatenate(
        [np.arange(T)[:, None], np.asarray(frame_times, np.float64)[:, None], to_opensim_axes(joints).reshape(T, -1)],
        axis=1,
    )
    with atomic_open(path, "w", encoding="ascii", newline="\n") as f:
        f.write(trc_text_header(path.name, fps, T))
        np.savetxt(f, table, fmt=["%d", "%.6f"] + ["%.6f"] * (table.shape[1] - 2), delimiter="\t")
    return path
