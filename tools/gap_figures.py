"""Figures of one continuous motion per person through detection gaps (one body), from lift results.

python tools/gap_figures.py track OUT/demo/demo.npz
    per person: frames present / filled by the prior, pelvis path length, largest pelvis step between
    consecutive present frames (gaps included, and the jump across a gap beyond --max-gap), each hypothesis's
    own pelvis path (least, most, median), and how much the median's bones change over the track (max - min over
    the median length, largest over the bones)
python tools/gap_figures.py cut OUT/demo/demo.npz CUT/demo.npz --person 1 --start 3.0 --seconds 1.5
    writes the lift's 2D keypoints (our keypoints npz, docs/keypoints.md) with person 1's detections removed
    from 3.0 s for 1.5 s: lift it again with the same options
python tools/gap_figures.py compare OUT/demo/demo.npz CUTOUT/demo/demo.npz --person 1
    the cut lift against the uncut one: in which share of the gap's frames every joint of the uncut median lies
    inside the cut lift's hypotheses (per coordinate between their 5 % and 95 % quantiles), the share of joints
    so inside, and the pelvis distance between the two medians after the gap (largest over the second after it,
    and over the rest of the track)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from platypose import load_result
from platypose.lifting.skeleton import bone_lengths


def track_figures(path: Path) -> None:
    """Print per person the path, step and bone figures of the lift at ``path``."""
    result = load_result(path)
    present, seen = result.present(), result.seen()
    for p, track in enumerate(result.track_ids):
        frames = np.flatnonzero(present[p])
        if len(frames) < 2:
            continue
        pelvis = np.asarray(result.median[p, frames, 0], np.float64)
        steps = np.linalg.norm(np.diff(pelvis, axis=0), axis=-1)  # between present frames: a jump across a split too
        own = np.asarray(result.hypotheses[p][:, frames, 0], np.float64)  # (N, t, 3)
        paths = np.linalg.norm(np.diff(own, axis=1), axis=-1).sum(axis=1)  # each hypothesis's own pelvis path
        bones = bone_lengths(np.asarray(result.median[p, frames], np.float64))  # (T, 16)
        change = (bones.max(0) - bones.min(0)) / np.median(bones, axis=0)
        print(
            f"p{track}: present {len(frames)} frames ({int((present[p] & ~seen[p]).sum())} filled by the prior), "
            f"pelvis path {steps.sum():.2f} m, largest step {steps.max():.3f} m (frame {frames[int(steps.argmax())]}), "
            f"hypotheses' own paths {paths.min():.1f}-{paths.max():.1f} m (median {np.median(paths):.1f}), "
            f"bone lengths change by up to {100 * change.max():.2f} %"
        )


def cut_keypoints(path: Path, out: Path, track: int, start: float, seconds: float) -> None:
    """Write the 2D keypoints of the lift at ``path`` without person ``track``'s from ``start`` for ``seconds``."""
    result = load_result(path)
    p = list(result.track_ids).index(track)
    keypoints = np.array(result.keypoints2d[:1], np.float32)  # (1, P, T, 17, 3): the first view
    times = np.asarray(result.frame_times)
    gone = (times >= start) & (times < start + seconds)
    keypoints[0, p, gone, :, :2] = np.nan
    keypoints[0, p, gone, :, 2] = 0.0
    camera = result.cameras[0]
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez(
        out,
        keypoints2d=keypoints,
        frame_times=times,
        track_ids=np.asarray(result.track_ids),
        joint_names=np.asarray(result.joint_names),
        image_size=np.array([camera.height, camera.width]),
        source=np.array(f"{path} without person {track} in {start:g}-{start + seconds:g} s"),
    )
    print(f"{out}: person {track} unseen in frames {np.flatnonzero(gone)[0]}-{np.flatnonzero(gone)[-1]}")


def compare(uncut_path: Path, cut_path: Path, track: int) -> None:
    """Print how the cut lift's hypotheses cover the uncut lift in its gap, and the pelvis after the gap."""
    uncut, cut = load_result(uncut_path), load_result(cut_path)
    p = list(cut.track_ids).index(track)
    q = list(uncut.track_ids).index(track)
    gap = cut.present()[p] & ~cut.seen()[p] & uncut.present()[q]
    frames = np.flatnonzero(gap)
    if not len(frames):
        print(f"p{track}: no frame filled by the prior in {cut_path}")
        return
    truth = np.asarray(uncut.median[q, frames], np.float64)  # (G, 17, 3)
    low, high = np.quantile(np.asarray(cut.hypotheses[p][:, frames], np.float64), [0.05, 0.95], axis=0)
    inside = ((truth >= low) & (truth <= high)).all(-1)  # (G, 17)
    after = np.arange(frames[-1] + 1, cut.num_frames)
    after = after[cut.present()[p, after] & uncut.present()[q, after]]
    distance = np.linalg.norm(cut.median[p, after, 0] - uncut.median[q, after, 0], axis=-1)
    second = after < frames[-1] + 1 + round(cut.fps)
    print(
        f"p{track}: {len(frames)} gap frames; every joint inside the cut lift's 5-95 % band in "
        f"{100 * inside.all(-1).mean():.0f} % of them ({100 * inside.mean():.1f} % of joints); pelvis after the gap "
        f"{distance[second].max(initial=0):.2f} m from the uncut lift (largest over 1 s), "
        f"{distance.max(initial=0):.2f} m (rest of the track)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="what", required=True)
    sub.add_parser("track").add_argument("npz", type=Path)
    cutter = sub.add_parser("cut")
    cutter.add_argument("npz", type=Path)
    cutter.add_argument("out", type=Path)
    compared = sub.add_parser("compare")
    compared.add_argument("uncut", type=Path)
    compared.add_argument("cut", type=Path)
    for command in (cutter, compared):
        command.add_argument("--person", type=int, required=True)
    cutter.add_argument("--start", type=float, required=True)
    cutter.add_argument("--seconds", type=float, default=1.5)
    args = parser.parse_args()
    if args.what == "track":
        track_figures(args.npz)
    elif args.what == "cut":
        cut_keypoints(args.npz, args.out, args.person, args.start, args.seconds)
    else:
        compare(args.uncut, args.cut, args.person)


if __name__ == "__main__":
    main()
