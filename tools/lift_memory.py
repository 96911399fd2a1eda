"""Peak memory of ``platypose lift`` against input length, on the bundled Pose2Sim keypoints looped.

    .venv/bin/python tools/lift_memory.py --minutes 0.5 1 2 4 --views 1 4 --work /tmp/lift-memory

For each length the 4 views' OpenPose keypoints (100 frames at 60 fps) are played
forwards and backwards until the length is reached and saved as per-camera npz
files; then each (views, length) runs ``platypose lift`` (all formats,
``--persons largest``, one thread) in a fresh process, whose peak resident memory
(``ru_maxrss`` from ``wait4``) and wall time are printed as a Markdown table row.
Extra arguments after ``--`` go to ``platypose lift`` (e.g. ``-- --samples 50``).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
TAKE = REPO / "data/video/pose2sim-balancing"
FPS = 60.0


def looped_keypoints(seconds: float, folder: Path) -> list[Path]:
    """Per-camera npz files ``folder/cam0<i>.npz`` holding ``seconds`` of the take's keypoints played back and forth."""
    from platypose.detectors.sources.keypoint_files import write_keypoints_npz
    from platypose.detectors.sources.keypoint_source import read_keypoints
    from platypose.detectors.sources.video import video_info
    from platypose.detectors.types import PoseTrack2D

    folder.mkdir(parents=True, exist_ok=True)
    frames = int(round(seconds * FPS))
    paths = []
    for i in range(1, 5):
        path = folder / f"cam0{i}.npz"
        paths.append(path)
        if path.exists():
            continue
        size = video_info(TAKE / f"cam0{i}.mp4").image_size
        view = read_keypoints(TAKE / f"openpose-body25b/cam0{i}_json", fps=FPS, image_size=size)
        cycle = np.concatenate([np.arange(view.num_frames), np.arange(view.num_frames - 2, 0, -1)])
        order = np.resize(cycle, frames)
        looped = PoseTrack2D(view.keypoints[order], np.arange(frames) / FPS, view.track_ids, size, str(path))
        write_keypoints_npz(looped, path)
    return paths


def run_lift(inputs: list[Path], out: Path, extra: list[str]) -> tuple[float, float]:
    """Run ``platypose lift`` on ``inputs`` in a new process; its peak RSS (MiB) and wall time (s)."""
    keypoints = str(inputs[0] if len(inputs) == 1 else inputs[0].parent)
    command = [
        sys.executable,
        "-m",
        "platypose",
        "lift",
        "--keypoints",
        keypoints,
        "--cams",
        str(TAKE / "calib_pose2sim.toml"),
        "--out",
        str(out),
        "--samples",
        "20",
        "--persons",
        "largest",
        "--threads",
        "1",
        "--quiet",
        "--formats",
        "npz,csv,bvh,rrd",
        *extra,
    ]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    started = time.perf_counter()
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(process.pid, 0)
    seconds = time.perf_counter() - started
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"platypose lift failed on {keypoints} (exit {os.waitstatus_to_exitcode(status)})")
    return usage.ru_maxrss / 1024, seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=float, nargs="+", default=[0.5, 1, 2, 4])
    parser.add_argument("--views", type=int, nargs="+", default=[1, 4], choices=[1, 4])
    parser.add_argument("--work", type=Path, default=Path("/tmp/lift-memory"))
    args, extra = parser.parse_known_args()
    extra = [a for a in extra if a != "--"]
    print("| views | minutes | frames | peak RSS (MiB) | wall (s) | load average |")
    print("|---|---|---|---|---|---|")
    for views in args.views:
        for minutes in args.minutes:
            inputs = looped_keypoints(60 * minutes, args.work / f"keypoints-{minutes:g}min")
            out = args.work / f"out-{views}v-{minutes:g}min"
            peak, seconds = run_lift(inputs[:1] if views == 1 else inputs, out, extra)
            load = " / ".join(f"{v:.1f}" for v in os.getloadavg())
            print(
                f"| {views} | {minutes:g} | {int(round(60 * minutes * FPS))} | {peak:.0f} | {seconds:.0f} | {load} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
