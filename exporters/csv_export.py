"""CSV exports: the long file (one row per person, hypothesis, frame, joint) and the per-joint summary.

Numbers are written with the shortest text that reads back to the same float32
(positions) or float64 (times), so the CSV holds the same numbers as the npz.
Frames where a person is absent are left out.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from platypose.exporters.frames import frame_chunks
from platypose.exporters.result import LiftResult
from platypose.lifting.atomic import atomic_open
from platypose.lifting.skeleton import JOINT_NAMES, NUM_JOINTS

LONG_COLUMNS = ("person", "hypothesis", "frame", "time_s", "joint", "x_m", "y_m", "z_m")
STATISTICS = ("median", "q05", "q95")
SUMMARY_COLUMNS = ("person", "frame", "time_s", "joint") + tuple(
    f"{label}_{axis}_m" for label in STATISTICS for axis in "xyz"
)


def _write_tables(tables: Iterable[pa.Table], columns: Sequence[str], path: Path) -> Path:
    """Write ``tables`` one after the other as one CSV with a plain header row, atomically."""
    with atomic_open(path) as f:
        f.write((",".join(columns) + "\n").encode())
        for table in tables:
            pacsv.write_csv(table, f, pacsv.WriteOptions(include_header=False, quoting_style="none"))
    return path


def _joint_column(count: int) -> pa.DictionaryArray:
    """Joint names repeated over ``count`` rows of 17 joints each."""
    indices = np.tile(np.arange(NUM_JOINTS, dtype=np.int32), count)
    return pa.DictionaryArray.from_arrays(indices, pa.array(JOINT_NAMES))


def long_tables(result: LiftResult) -> Iterator[pa.Table]:
    """Rows ``person, hypothesis, frame, time_s, joint, x_m, y_m, z_m`` over present frames, a chunk at a time.

    Rows are ordered by person, hypothesis, frame and joint.
    """
    present = result.present()
    for p, track in enumerate(result.track_ids):
        for n in range(result.num_hypotheses):
            for t in frame_chunks(result.num_frames):
                t_idx = t.start + np.flatnonzero(present[p, t])
                if len(t_idx) == 0:
                    continue
                xyz = result.hypotheses[p, n, t][t_idx - t.start].reshape(-1, 3)
                yield pa.table(
                    {
                        "person": np.full(len(xyz), track),
                        "hypothesis": np.full(len(xyz), n),
                        "frame": np.repeat(t_idx, NUM_JOINTS),
                        "time_s": np.repeat(result.frame_times[t_idx], NUM_JOINTS),
                        "joint": _joint_column(len(t_idx)),
                        "x_m": xyz[:, 0],
                        "y_m": xyz[:, 1],
                        "z_m": xyz[:, 2],
                    }
                )


def summary_arrays(hypotheses: np.ndarray, median: np.ndarray) -> dict[str, np.ndarray]:
    """The median (..., 17, 3) and the 5/95% quantiles of ``hypotheses`` (N, ..., 17, 3) over hypotheses."""
    q05, q95 = np.quantile(hypotheses, [0.05, 0.95], axis=0).astype(np.float32)
    return {"median": median, "q05": q05, "q95": q95}


def summary_tables(result: LiftResult) -> Iterator[pa.Table]:
    """Rows ``person, frame, time_s, joint, median_{x,y,z}_m, q05_..., q95_...`` over present frames, in chunks."""
    present = result.present()
    for p, track in enumerate(result.track_ids):
        for t in frame_chunks(result.num_frames):
            on = np.flatnonzero(present[p, t])
            if len(on) == 0:
                continue
            t_idx = t.start + on
            stats = summary_arrays(result.hypotheses[p, :, t][:, on], result.median[p, t][on])
            columns: dict[str, object] = {
                "person": np.full(len(on) * NUM_JOINTS, track),
                "frame": np.repeat(t_idx, NUM_JOINTS),
                "time_s": np.repeat(result.frame_times[t_idx], NUM_JOINTS),
                "joint": _joint_column(len(on)),
            }
            for label in STATISTICS:
                values = stats[label].reshape(-1, 3)
                for axis, name in enumerate("xyz"):
                    columns[f"{label}_{name}_m"] = values[:, axis]
            yield pa.table(columns)


def write_long_csv(result: LiftResult, path: Path | str) -> Path:
    """Write the long CSV to ``path`` atomically, a chunk of frames at a time."""
    return _write_tables(long_tables(result), LONG_COLUMNS, Path(path))


def write_summary_csv(result: LiftResult, path: Path | str) -> Path:
    """Write the summary CSV to ``path`` atomically, a chunk of frames at a time."""
    return _write_tables(summary_tables(result), SUMMARY_COLUMNS, Path(path))
