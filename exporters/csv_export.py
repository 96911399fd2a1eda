"""CSV exports: the long file (one row per person, hypothesis, frame, joint) and the per-joint summary.

Numbers are written with the shortest text that reads back to the same float32
(positions) or float64 (times), so the CSV holds the same numbers as the npz.
Every frame of a person seen at least once is written; frames where the person
is absent are filled by the rule of :mod:`exporters.gaps`; they, and the frames the prior filled through a
detection gap, have ``filled`` 1.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from platypose.exporters.frames import Lead, frame_chunks
from platypose.exporters.gaps import fill_frames, person_plans
from platypose.exporters.result import LiftResult
from platypose.lifting.atomic import atomic_open
from platypose.lifting.skeleton import JOINT_NAMES, NUM_JOINTS

LONG_COLUMNS = ("person", "hypothesis", "frame", "time_s", "joint", "x_m", "y_m", "z_m", "filled")
STATISTICS = ("median", "q05", "q95")
SUMMARY_COLUMNS = (
    ("person", "frame", "time_s", "joint") + tuple(f"{label}_{axis}_m" for label in STATISTICS for axis in "xyz")
) + ("filled",)


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
    """Rows ``person, hypothesis, frame, time_s, joint, x_m, y_m, z_m, filled`` over all frames, a chunk at a time.

    Rows are ordered by person, hypothesis, frame and joint.
    """
    for p, plan in person_plans(result).items():
        track = result.track_ids[p]
        for n in range(result.num_hypotheses):
            for t in frame_chunks(result.num_frames):
                xyz = fill_frames(Lead(result.hypotheses, p, n), plan, t).reshape(-1, 3)
                frames = np.arange(t.start, t.stop)
                yield pa.table(
                    {
                        "person": np.full(len(xyz), track),
                        "hypothesis": np.full(len(xyz), n),
                        "frame": np.repeat(frames, NUM_JOINTS),
                        "time_s": np.repeat(result.frame_times[t], NUM_JOINTS),
                        "joint": _joint_column(len(frames)),
                        "x_m": xyz[:, 0],
                        "y_m": xyz[:, 1],
                        "z_m": xyz[:, 2],
                        "filled": np.repeat(plan.filled[t], NUM_JOINTS).astype(np.int8),
                    }
                )


def summary_arrays(hypotheses: np.ndarray, median: np.ndarray) -> dict[str, np.ndarray]:
    """The median (..., 17, 3) and the 5/95% quantiles of ``hypotheses`` (N, ..., 17, 3) over hypotheses."""
    q05, q95 = np.quantile(hypotheses, [0.05, 0.95], axis=0).astype(np.float32)
    return {"median": median, "q05": q05, "q95": q95}


def summary_tables(result: LiftResult) -> Iterator[pa.Table]:
    """Rows ``person, frame, time_s, joint, median_{x,y,z}_m, q05_..., q95_..., filled`` over all frames, in chunks."""
    for p, plan in person_plans(result).items():
        for t in frame_chunks(result.num_frames):
            frames = np.arange(t.start, t.stop)
            hyp = fill_frames(Lead(result.hypotheses, p), plan, t, axis=1)
            stats = summary_arrays(hyp, fill_frames(Lead(result.median, p), plan, t))
            columns: dict[str, object] = {
                "person": np.full(len(frames) * NUM_JOINTS, result.track_ids[p]),
                "frame": np.repeat(frames, NUM_JOINTS),
                "time_s": np.repeat(result.frame_times[t], NUM_JOINTS),
                "joint": _joint_column(len(frames)),
            }
            for label in STATISTICS:
                values = stats[label].reshape(-1, 3)
                for axis, name in enumerate("xyz"):
                    columns[f"{label}_{name}_m"] = values[:, axis]
            columns["filled"] = np.repeat(plan.filled[t], NUM_JOINTS).astype(np.int8)
            yield pa.table(columns)


def write_long_csv(result: LiftResult, path: Path | str) -> Path:
    """Write the long CSV to ``path`` atomically, a chunk of frames at a time."""
    return _write_tables(long_tables(result), LONG_COLUMNS, Path(path))


def write_summary_csv(result: LiftResult, path: Path | str) -> Path:
    """Write the summary CSV to ``path`` atomically, a chunk of frames at a time."""
    return _write_tables(summary_tables(result), SUMMARY_COLUMNS, Path(path))
