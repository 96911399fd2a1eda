"""Finishing (``finish_take``: depth steadying, the gap check, bodies) of an earlier lift on 1 and more threads,
timed back to back, with the arrays compared.

    .venv/bin/python tools/finish_figures.py OUT/<name>/<name>.npz [--workers 1,2] [--repeats 2]

The npz's hypotheses and median (finished already: the timing, not the figures, is what this measures) are
finished again on copies, with no floor, for each worker count in turn, ``--repeats`` times; prints the seconds and
whether each run's arrays equal the first run's (one worker)."""

from __future__ import annotations

import argparse
import time

import numpy as np

from platypose.exporters.npz import read_npz
from platypose.lifting.finish.steps import finish_take
from platypose.lifting.job_log import JobLog
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.take import Take


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("npz")
    parser.add_argument("--workers", default="1,2", help="worker counts, comma-separated")
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    result = read_npz(args.npz)
    hypotheses, median = np.array(result.hypotheses, np.float32), np.array(result.median, np.float32)
    keypoints = np.moveaxis(np.asarray(result.keypoints2d), 1, 2)  # (C, T, P, 17, 3)
    roots = [None] * hypotheses.shape[0]
    take = Take.on_clock(
        keypoints, np.asarray(result.frame_times), np.asarray(result.track_ids), list(result.cameras), roots,
        sampler=SamplerConfig(), windows=WindowSettings(),
    )  # fmt: skip
    first = None
    for _ in range(args.repeats):
        for workers in (int(w) for w in args.workers.split(",")):
            h, m = hypotheses.copy(), median.copy()
            began = time.perf_counter()
            finish_take(take, hypotheses=h, median=m, fps=float(result.fps), floor=None, log=JobLog(), workers=workers)
            seconds = time.perf_counter() - began
            first = first or (h, m)
            same = np.array_equal(h, first[0], equal_nan=True) and np.array_equal(m, first[1], equal_nan=True)
            arrays = "identical to" if same else "DIFFERENT from"
            print(f"workers {workers}: {seconds:.2f} s, arrays {arrays} the first run's")


if __name__ == "__main__":
    main()
