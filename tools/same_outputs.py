"""Whether a change left the lifts as they were: the same takes lifted by two checkouts, every output compared.

A refactor must not move a number. ``lift`` runs five lifts that cover the take path's branches with a checkout's
Python (two views detected, four views of keypoints, one view split into pieces on two processes, one view without
a calibration, one view with its calibration); ``compare`` holds two such folders against each other: every npz
array equal (NaN where NaN), ``meta`` equal once its timings and the folders' own paths are left out, and the BVH,
TRC and CSV files equal byte for byte. Run from the repository root:

    python tools/same_outputs.py lift /tmp/after
    python tools/same_outputs.py lift /tmp/before --python ../before/.venv/bin/python
    python tools/same_outputs.py compare /tmp/before /tmp/after

``lift`` takes a few minutes on 2 cores; ``compare`` prints each difference and a count, and exits 1 on any.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

TAKE = "data/video/pose2sim-balancing"
DEMO = "data/video/sports2d-demo"
SPORTS = [f"{DEMO}/demo.mp4"]
CASES = {
    "demo": ["demo", "--samples", "20"],
    "kp4": ["demo", "--source", "keypoints", "--samples", "20"],
    "split": ["lift", *SPORTS, "--cams", f"{DEMO}/Calib_demo.toml", "--max-gap", "0.5", "--split-seconds", "3"]
    + ["--jobs", "2", "--samples", "10", "--formats", "npz,bvh,trc"],
    "one": ["lift", *SPORTS, "--samples", "10", "--formats", "npz,bvh"],
    "onecal": ["lift", *SPORTS, "--cams", f"{DEMO}/Calib_demo.toml", "--floor", "auto", "--samples", "10"]
    + ["--formats", "npz"],
}
TEXTS = (".bvh", ".trc", ".csv")


def lift(out: Path, python: str) -> None:
    """Run every case with ``python -m platypose`` into ``out/<case>``, each case's console in ``out/<case>.log``."""
    out.mkdir(parents=True, exist_ok=True)
    for name, args in CASES.items():
        with open(out / f"{name}.log", "w") as log:
            command = [python, "-m", "platypose", *args, "--out", str(out / name), "-q"]
            done = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, check=False)
        print(f"{name}: exit {done.returncode}")
        if done.returncode != 0:
            sys.exit(f"{name} failed: see {out / name}.log")


def plain_meta(text: str, folder: Path) -> dict:
    """A result's meta without its timings, the output folder replaced by a placeholder and
    the bundled data named from the checkout on."""
    text = text.replace(str(folder.resolve()), "<out>").replace(str(folder), "<out>")
    text = re.sub(r'/[^\s"]*?/(data/video/)', r"\1", text)  # absolute or relative: the bundled data
    meta = json.loads(text)
    meta.pop("timings", None)
    return meta


def array_differences(a: Path, b: Path, name: str) -> list[str]:
    """Every way the npz ``a`` differs from ``b`` (``name``: how to call it)."""
    with np.load(a, allow_pickle=False) as left, np.load(b, allow_pickle=False) as right:
        if set(left.files) != set(right.files):
            return [f"{name}: keys {sorted(set(left.files) ^ set(right.files))}"]
        found = []
        for key in left.files:
            if key == "key" and name.endswith(".detections.npz"):
                continue  # a detection cache's key holds the video's path
            x, y = left[key], right[key]
            if key == "meta":
                x, y = plain_meta(str(x), a.parents[1]), plain_meta(str(y), b.parents[1])
                if x != y:
                    found.append(f"{name}: meta {sorted(k for k in x.keys() | y.keys() if x.get(k) != y.get(k))}")
            elif x.shape != y.shape or not np.array_equal(x, y, equal_nan=x.dtype.kind in "fc"):
                found.append(f"{name}: {key} {x.shape} {y.shape}")
        return found


def compare(before: Path, after: Path) -> int:
    """Print the differences between two ``lift`` folders; their count."""
    found, arrays = [], 0
    for a in sorted(before.rglob("*")):
        name = str(a.relative_to(before))
        b = after / name
        if a.suffix not in (".npz", *TEXTS) or not a.is_file():
            continue
        if not b.is_file():
            found.append(f"{name}: missing in {after}")
        elif a.suffix == ".npz":
            found += array_differences(a, b, name)
            arrays += 1
        elif a.read_bytes() != b.read_bytes():
            found.append(f"{name}: the files differ")
    for line in found:
        print(line)
    print(f"{arrays} npz files compared, {len(found)} differences")
    return len(found)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    verbs = parser.add_subparsers(dest="verb", required=True)
    run = verbs.add_parser("lift", help="lift the cases into a folder")
    run.add_argument("out", type=Path)
    run.add_argument("--python", default=sys.executable, help="the checkout's Python (default: this one)")
    held = verbs.add_parser("compare", help="compare two folders lifted by `lift`")
    held.add_argument("before", type=Path)
    held.add_argument("after", type=Path)
    args = parser.parse_args()
    if args.verb == "lift":
        lift(args.out, args.python)
    else:
        sys.exit(1 if compare(args.before, args.after) else 0)


if __name__ == "__main__":
    main()
