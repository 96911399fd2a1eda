"""A take lifted whole and with ``--split-seconds``: the same persons and track ids, each person's pelvis against the
unsplit lift's, and the pelvis steps around the seams.

    .venv/bin/python tools/split_figures.py [--split 3] [--samples 20] [--split-args "--jobs 2"] [--loop 1]

Lifts the sports2d demo (``data/video/sports2d-demo/demo.mp4`` with ``Calib_demo.toml``, one camera, two persons,
7.7 s at 30 fps; ``--loop K`` concatenates it K times into a temporary video first) with ``platypose lift --formats
npz --threads 1``, once unsplit (one process) and once with ``--split-seconds S`` plus ``--split-args`` (``--jobs 2``
or ``--executor ray``), each into a fresh output folder, and prints per person: frames present in each, the median
over frames of the distance between the two lifts' representative pelvis positions, the largest frame-to-frame
step of the split lift's representative pelvis within one second of a seam (and of the unsplit lift at the same
frames: a person who falls steps as far in both), and the largest step there of the split pelvis relative to the
unsplit one (what the seam adds); then wall times and the load average before and after.
"""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from platypose.data import VIDEO_DIR
from platypose.exporters.npz import read_npz

TAKE = VIDEO_DIR / "sports2d-demo"
NEAR_SEAM_S = 1.0  # steps counted within this many seconds of a seam


def loadavg() -> str:
    """The first three figures of /proc/loadavg."""
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def looped(video: Path, times: int, folder: Path) -> Path:
    """``video`` concatenated ``times`` times (stream copy with PyAV: the same frames, stamps shifted)."""
    import av

    target = folder / f"{video.stem}-x{times}.mp4"
    with av.open(str(video)) as first:
        source = first.streams.video[0]
        with av.open(str(target), "w") as out:
            stream = out.add_stream_from_template(source)
            offset = 0
            for _ in range(times):
                with av.open(str(video)) as again:
                    last = 0
                    for packet in again.demux(again.streams.video[0]):
                        if packet.pts is None or packet.size == 0:
                            continue
                        last = max(last, packet.pts + (packet.duration or 0))
                        packet.pts += offset
                        packet.dts = None if packet.dts is None else packet.dts + offset
                        packet.stream = stream
                        out.mux(packet)
                offset += last
    return target


def lift(video: Path, out: Path, samples: int, extra: list[str]) -> float:
    """Run ``platypose lift`` on ``video`` into ``out``; its wall seconds."""
    command = [sys.executable, "-m", "platypose", "lift", str(video), "--cams", str(TAKE / "Calib_demo.toml")]
    command += ["--samples", str(samples), "--formats", "npz", "--threads", "1", "-q", "--out", str(out), *extra]
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    return time.perf_counter() - started


def figures(whole_npz: Path, split_npz: Path, split_s: float) -> list[str]:
    """Lines comparing the two results (see the module's docstring)."""
    whole, split = read_npz(whole_npz), read_npz(split_npz)
    lines = [f"track ids: unsplit {list(map(int, whole.track_ids))}, split {list(map(int, split.track_ids))}"]
    times = whole.frame_times - whole.frame_times[0]
    seams = np.arange(split_s, times[-1], split_s)
    near = np.zeros(len(times) - 1, bool)
    for seam in seams:
        near |= np.abs(times[1:] - seam) <= NEAR_SEAM_S
    for p, track in enumerate(whole.track_ids):
        q = list(split.track_ids).index(track) if track in split.track_ids else None
        if q is None:
            lines.append(f"person {track}: missing from the split lift")
            continue
        a, b = whole.median[p][:, 0], split.median[q][:, 0]  # (T, 3) pelvis
        both = np.isfinite(a).all(-1) & np.isfinite(b).all(-1)
        distance = np.linalg.norm(a[both] - b[both], axis=-1)
        step_b = np.linalg.norm(np.diff(b, axis=0), axis=-1)
        step_a = np.linalg.norm(np.diff(a, axis=0), axis=-1)
        around = near & np.isfinite(step_b)
        if not around.any():
            lines.append(f"person {track}: not present near a seam")
            continue
        at = int(np.flatnonzero(around)[np.argmax(step_b[around])])
        offset = np.linalg.norm(np.diff(b - a, axis=0), axis=-1)  # how the split lift's pelvis moves against the other
        lines.append(
            f"person {track}: present {int(np.isfinite(a).all(-1).sum())} / {int(np.isfinite(b).all(-1).sum())} "
            f"frames (unsplit / split); pelvis apart {np.median(distance):.3f} m median, {distance.max():.3f} m max; "
            f"within {NEAR_SEAM_S:g} s of a seam: largest pelvis step {step_b[at]:.3f} m (frames {at}-{at + 1}; the "
            f"unsplit lift's there {step_a[at]:.3f} m, its largest near seams {np.nanmax(step_a[around]):.3f} m), "
            f"largest step of the split lift's pelvis relative to the unsplit's {np.nanmax(offset[around]):.3f} m"
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--split", type=float, default=3.0, help="--split-seconds")
    parser.add_argument("--samples", type=int, default=20)
    parser.add_argument("--split-args", default="--jobs 2", help="how the pieces run")
    parser.add_argument("--loop", type=int, default=1, help="concatenate the demo this many times")
    parser.add_argument("--skip-unsplit", action="store_true", help="time the split lift only")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="split-figures-") as scratch:
        folder = Path(scratch)
        video = TAKE / "demo.mp4" if args.loop == 1 else looped(TAKE / "demo.mp4", args.loop, folder)
        print(f"load before: {loadavg()}")
        seconds = {}
        if not args.skip_unsplit:
            seconds["unsplit"] = lift(video, folder / "whole", args.samples, [])
            print(f"unsplit: {seconds['unsplit']:.1f} s (load {loadavg()})")
        extra = ["--split-seconds", f"{args.split:g}", *shlex.split(args.split_args)]
        seconds["split"] = lift(video, folder / "split", args.samples, extra)
        print(f"split {' '.join(extra)}: {seconds['split']:.1f} s (load {loadavg()})")
        if "unsplit" in seconds:
            print(f"split / unsplit wall time: {seconds['split'] / seconds['unsplit']:.2f}")
            name = video.stem
            for line in figures(
                folder / "whole" / name / f"{name}.npz", folder / "split" / name / f"{name}.npz", args.split
            ):
                print(line)


if __name__ == "__main__":
    main()
