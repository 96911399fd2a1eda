"""CSV exports: the people's file (one row per person and frame: each joint's answer and how far the hypotheses
spread around it) and, on request, the long file (one row per person, hypothesis, frame and joint).

The people's file rounds to the millimetre (the hypotheses spread by centimetres; the npz keeps every digit). The
long file writes the shortest text that reads back to the same float32 (positions) or float64 (times), so it holds
the npz's numbers. Both hold every frame of a person seen at least once; frames where the person is absent are
filled by the rule of :mod:`exporters.gaps`; they, and the frames the prior filled through a detection gap,
have ``filled`` 1.
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
from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.skeleton import JOINT_NAMES, NUM_JOINTS

LONG_COLUMNS = ("person", "hypothesis", "frame", "time_s", "joint", "x_m", "y_m", "z_m", "filled")
SPREAD = 0.9  # the quantile of the hypotheses' distances to the answer in the people's file: <joint>_r90_m
PEOPLE_COLUMNS = ("person", "frame", "time_s", "filled") + tuple(
    f"{joint}_{value}_m" for joint in JOINT_NAMES for value in ("x", "y", "z", f"r{round(SPREAD * 100)}")
)
DECIMALS = 3  # the people's file: millimetres, as metres
TIME_DECIMALS = 6  # and microseconds


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


def spread_radius(hypotheses: np.ndarray, answer: np.ndarray, quantile: float = SPREAD) -> np.ndarray:
    """The ``quantile`` of the distances of ``hypotheses`` (N, ..., 3) to ``answer`` (..., 3): (...,), the radius
    around the answer that holds that share of the hypotheses."""
    return np.quantile(np.linalg.norm(hypotheses - answer, axis=-1), quantile, axis=0)


def _rounded(values: np.ndarray, decimals: int) -> np.ndarray:
    """``values`` as float64 rounded to ``decimals``, -0.0 written as 0."""
    return np.round(np.asarray(values, dtype=np.float64), decimals) + 0.0


def people_tables(result: LiftResult) -> Iterator[pa.Table]:
    """Rows ``person, frame, time_s, filled`` then per joint ``<joint>_x_m, _y_m, _z_m, _r90_m`` (the answer, the
    npz ``median``, and the radius holding 90 % of the hypotheses), millimetres, over all frames, in chunks."""
    for p, plan in person_plans(result).items():
        for t in frame_chunks(result.num_frames):
            frames = np.arange(t.start, t.stop)
            answer = fill_frames(Lead(result.median, p), plan, t)
            radius = spread_radius(fill_frames(Lead(result.hypotheses, p), plan, t, axis=1), answer)
            values = np.concatenate([answer, radius[..., None]], axis=-1).reshape(len(frames), -1)
            columns: dict[str, object] = {
                "person": np.full(len(frames), result.track_ids[p]),
                "frame": frames,
                "time_s": _rounded(result.frame_times[t], TIME_DECIMALS),
                "filled": plan.filled[t].astype(np.int8),
            }
            for k, name in enumerate(PEOPLE_COLUMNS[4:]):
                columns[name] = _rounded(values[:, k], DECIMALS)
            yield pa.table(columns)


def write_long_csv(result: LiftResult, path: Path | str) -> Path:
    """Write the long CSV (every hypothesis) to ``path`` atomically, a chunk of frames at a time."""
    return _write_tables(long_tables(result), LONG_COLUMNS, Path(path))


def write_people_csv(result: LiftResult, path: Path | str) -> Path:
    """Write the people's CSV to ``path`` atomically, a chunk of frames at a time."""
    return _write_tables(people_tables(result), PEOPLE_COLUMNS, Path(path))
