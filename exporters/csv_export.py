"""CSV exports: the long file (one row per person, hypothesis, frame, joint) and the per-joint summary.

Numbers are written with the shortest text that reads back to the same float32
(positions) or float64 (times), so the CSV holds the same numbers as the npz.
Frames where a person is absent are left out.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from exporters.result import LiftResult
from lifting.atomic import atomic_open
from lifting.skeleton import JOINT_NAMES, NUM_JOINTS

LONG_COLUMNS = ("person", "hypothesis", "frame", "time_s", "joint", "x_m", "y_m", "z_m")
STATISTICS = ("median", "q05", "q95")
SUMMARY_COLUMNS = ("person", "frame", "time_s", "joint") + tuple(
    f"{label}_{axis}_m" for label in STATISTICS for axis in "xyz"
)


def _write_table(table: pa.Table, path: Path) -> Path:
    """Write ``table`` as CSV with a plain header row, atomically."""
    with atomic_open(path) as f:
        f.write((",".join(table.column_names) + "\n").encode())
        pacsv.write_csv(table, f, pacsv.WriteOptions(include_header=False, quoting_style="none"))
    return path


def _joint_column(count: int) -> pa.DictionaryArray:
    """Joint names repeated over ``count`` rows of 17 joints each."""
    indices = np.tile(np.arange(NUM_JOINTS, dtype=np.int32), count)
    return pa.DictionaryArray.from_arrays(indices, pa.array(JOINT_NAMES))


def long_table(result: LiftResult) -> pa.Table:
    """Rows ``person, hypothesis, frame, time_s, joint, x_m, y_m, z_m`` over present frames."""
    P, N, T = result.hypotheses.shape[:3]
    present = result.present()
    p_idx, n_idx, t_idx = np.nonzero(np.broadcast_to(present[:, None, :], (P, N, T)))
    xyz = result.hypotheses[p_idx, n_idx, t_idx].reshape(-1, 3)
    rep = NUM_JOINTS
    return pa.table(
        {
            "person": np.repeat(result.track_ids[p_idx], rep),
            "hypothesis": np.repeat(n_idx, rep),
            "frame": np.repeat(t_idx, rep),
            "time_s": np.repeat(result.frame_times[t_idx], rep),
            "joint": _joint_column(len(p_idx)),
            "x_m": xyz[:, 0],
            "y_m": xyz[:, 1],
            "z_m": xyz[:, 2],
        }
    )


def summary_arrays(result: LiftResult) -> dict[str, np.ndarray]:
    """Per person, frame and joint: the npz median and 5/95% quantiles over hypotheses, each (P, T, 17, 3)."""
    q05, q95 = np.quantile(result.hypotheses, [0.05, 0.95], axis=1).astype(np.float32)
    return {"median": result.median, "q05": q05, "q95": q95}


def summary_table(result: LiftResult) -> pa.Table:
    """Rows ``person, frame, time_s, joint, median_{x,y,z}_m, q05_..., q95_...`` over present frames."""
    p_idx, t_idx = np.nonzero(result.present())
    stats = summary_arrays(result)
    columns: dict[str, object] = {
        "person": np.repeat(result.track_ids[p_idx], NUM_JOINTS),
        "frame": np.repeat(t_idx, NUM_JOINTS),
        "time_s": np.repeat(result.frame_times[t_idx], NUM_JOINTS),
        "joint": _joint_column(len(p_idx)),
    }
    for label in STATISTICS:
        values = stats[label][p_idx, t_idx].reshape(-1, 3)
        for axis, name in enumerate("xyz"):
            columns[f"{label}_{name}_m"] = values[:, axis]
    return pa.table(columns)


def write_long_csv(result: LiftResult, path: Path | str) -> Path:
    """Write the long CSV to ``path`` atomically."""
    return _write_table(long_table(result), Path(path))


def write_summary_csv(result: LiftResult, path: Path | str) -> Path:
    """Write the summary CSV to ``path`` atomically."""
    return _write_table(summary_table(result), Path(path))
