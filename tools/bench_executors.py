"""Throughput of ``platypose lift`` batches: ``--jobs 1/2`` against ``--executor ray`` with 1 and 2 local workers.

    OMP_NUM_THREADS=1 .venv/bin/python tools/bench_executors.py --inputs 4 --rounds 2 [--samples N] [--frames F]

The batch is ``--inputs`` copies of the bundled Pose2Sim take (cam01 + cam02 videos, its calibration), each a
folder of links to the videos, so every input is a real 2-view take of 100 frames (1.7 s at 60 fps) that is
detected and lifted; ``--frames`` cuts the videos shorter (written with OpenCV). Every configuration runs in
its own ``platypose lift`` process into a fresh ``--out`` (no detection cache), configurations alternate within
each round, and the table gives medians over rounds. Ray runs start a private local instance of all cores;
``--cpus-per-input 2`` runs one input at a time (as ``--jobs 1``), ``--cpus-per-input 1`` two (as ``--jobs 2``);
every run has ``--threads 1``. Ray's start-up is measured alone (``ray.init`` to the first task done,
in a fresh process) and subtracted for the steady throughput. The overhead per input is (Ray wall - start-up - local wall) / inputs at
the same number of workers. The last column is measured within each run, so it moves less with the machine's
load: wall seconds x workers / inputs minus the seconds each input's run took where it ran (process start,
imports, Ray start-up and scheduling, and workers idle at the end of the batch).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from platypose.data import VIDEO_DIR

TAKE = VIDEO_DIR / "pose2sim-balancing"
CONFIGS = {
    "--jobs 1": ["--jobs", "1"],
    "--jobs 2": ["--jobs", "2"],
    "ray, 1 worker": ["--executor", "ray", "--cpus-per-input", "2"],
    "ray, 2 workers": ["--executor", "ray", "--cpus-per-input", "1"],
}

RAY_START = """
import os, time
os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
started = time.perf_counter()
import ray
ray.init(include_dashboard=False, log_to_driver=False, logging_level="WARNING")
ray.get(ray.remote(lambda: 0).remote())
print(time.perf_counter() - started)
ray.shutdown()
"""


def make_batch(folder: Path, inputs: int, frames: int | None) -> Path:
    """``inputs`` take folders of cam01 + cam02 (links, or the first ``frames`` frames written anew)."""
    sources = [TAKE / "cam01.mp4", TAKE / "cam02.mp4"]
    if frames is not None:
        import cv2

        from platypose.detectors.sources.video import iter_frames

        cut = []
        for video in sources:
            images = [f for _, f in iter_frames(video, max_frames=frames)]
            path = folder / video.name
            writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 60.0, images[0].shape[1::-1])
            for image in images:
                writer.write(image)
            writer.release()
            cut.append(path)
        sources = cut
    batch = folder / "batch"
    for i in range(inputs):
        take = batch / f"take{i:03d}"
        take.mkdir(parents=True)
        for video in sources:
            (take / video.name).symlink_to(video)
    return batch


def run_lift(batch: Path, out: Path, extra: list[str], samples: int | None) -> tuple[float, float]:
    """Wall seconds of one ``platypose lift`` process over the batch, and the seconds its inputs' runs took (the
    summary's, measured around each input's run where it ran)."""
    args = ["lift", str(batch), "--cams", str(TAKE / "calib_pose2sim.toml"), "--out", str(out), "--quiet"]
    args += ["--threads", "1"]  # 2 torch threads on a busy 2-core machine are many times slower (docs/lift.md)
    args += ["--samples", str(samples)] if samples else []
    command = [sys.executable, "-m", "platypose", *args, *extra]
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(extra)} failed:\n{done.stderr[-2000:]}")
    entries = json.loads((out / "summary.json").read_text())["inputs"]
    return seconds, sum(e["seconds"] for e in entries)


def ray_start_seconds() -> float:
    """Seconds from ``ray.init`` of a local instance to its first task's result, in a fresh process."""
    done = subprocess.run([sys.executable, "-c", RAY_START], capture_output=True, text=True)
    return float(done.stdout.strip().splitlines()[-1])


def main() -> None:
    """Run the rounds and print a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--inputs", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--samples", type=int, default=None, help="hypotheses per person [lift's default]")
    parser.add_argument("--frames", type=int, default=None, help="cut the videos to this many frames")
    options = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    walls: dict[str, list[float]] = {name: [] for name in CONFIGS}
    outside: dict[str, list[float]] = {name: [] for name in CONFIGS}  # per input: wall x workers / n - run
    starts: list[float] = []
    with tempfile.TemporaryDirectory(prefix="bench-executors-") as scratch:
        batch = make_batch(Path(scratch), options.inputs, options.frames)
        for round_ in range(options.rounds):
            for name, extra in CONFIGS.items():
                out = Path(scratch) / "out"
                wall, inputs_s = run_lift(batch, out, extra, options.samples)
                walls[name].append(wall)
                workers = 1 if name in ("--jobs 1", "ray, 1 worker") else 2
                outside[name].append((wall * workers - inputs_s) / options.inputs)
                shutil.rmtree(out)
                print(f"round {round_ + 1} {name}: {walls[name][-1]:.1f} s", file=sys.stderr, flush=True)
            starts.append(ray_start_seconds())
    n = options.inputs
    print(
        f"{n} inputs, {options.rounds} rounds, medians; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    )
    print(
        "| run | wall s | inputs / min | Ray start-up s | inputs / min after start-up | overhead / input s "
        "| worker time outside the inputs' runs, s / input |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name, values in walls.items():
        wall = statistics.median(values)
        if name.startswith("ray"):
            workers = 1 if "1 worker" in name else 2
            start = statistics.median(starts)
            local = statistics.median(walls[f"--jobs {workers}"])
            steady = f"{60 * n / (wall - start):.2f}"
            overhead = f"{(wall - start - local) / n:.2f}"
            start_text = f"{start:.1f}"
        else:
            steady, overhead, start_text = f"{60 * n / wall:.2f}", "", ""
        around = statistics.median(outside[name])
        print(f"| {name} | {wall:.1f} | {60 * n / wall:.2f} | {start_text} | {steady} | {overhead} | {around:.1f} |")


if __name__ == "__main__":
    main()
