"""Print figures of lifts: facing flips and left/right swaps against the images.

    .venv/bin/python tools/facing_figures.py OUT/<job>/<job>.npz ...

Per person present in at least half the frames of each npz, one Markdown table row:

- turns >60: share of consecutive present hypothesis-frame pairs whose pelvis heading (the horizontal normal of the
  hip line) turns by more than 60 degrees (at 30 fps: 1,800 deg/s), and of the answer's;
- brief turns: hypothesis-frames inside a run of at most 0.5 s whose heading is more than 90 degrees from the heading
  both before and after it (a body facing the wrong way for a few frames), per thousand;
- swapped legs / arms: share of hypothesis-frames whose legs (hips, knees, ankles) or arms (shoulders, elbows,
  wrists), projected into the view that sees the person, lie closer to the keypoints of the other side than to their
  own (by at least half of their own distance and 10 px); and the answer's. The keypoints are first relabelled by
  continuity (:func:`platypose.detectors.tracking.side_swaps.repair_side_swaps`), so that a detector's own swap in
  a frame does not count as the lift's, before and after that repair alike.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from platypose.detectors.tracking.side_swaps import repair_side_swaps
from platypose.exporters.npz import read_npz
from platypose.lifting.camera import project
from platypose.lifting.skeleton import JOINT_INDEX, MIRROR

TURN_DEG = 60.0
BRIEF_S = 0.5
LEGS = tuple(JOINT_INDEX[f"{s}_{j}"] for s in ("left", "right") for j in ("hip", "knee", "ankle"))
ARMS = tuple(JOINT_INDEX[f"{s}_{j}"] for s in ("left", "right") for j in ("shoulder", "elbow", "wrist"))


def headings(motion: np.ndarray) -> np.ndarray:
    """Pelvis heading angle (radians about Z) of motions ``(..., 17, 3)``: the horizontal normal of the hip line."""
    across = motion[..., JOINT_INDEX["left_hip"], :2] - motion[..., JOINT_INDEX["right_hip"], :2]
    return np.arctan2(across[..., 0], -across[..., 1])  # forward = up x (left - right), rotated a quarter turn


def turn_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Absolute angle (degrees) between headings ``a`` and ``b``."""
    return np.degrees(np.abs(np.angle(np.exp(1j * (a - b)))))


def turn_share(motions: np.ndarray) -> float:
    """Share of consecutive present frame pairs of motions ``(K, T, 17, 3)`` turning by more than ``TURN_DEG``."""
    heading = headings(motions)
    pair = np.isfinite(heading[:, 1:]) & np.isfinite(heading[:, :-1])
    turns = turn_between(heading[:, 1:], heading[:, :-1])
    return float((turns[pair] > TURN_DEG).mean()) if pair.any() else 0.0


def brief_turn_frames(heading: np.ndarray, fps: float) -> int:
    """Frames of one motion's headings ``(T,)`` inside a run of at most ``BRIEF_S`` facing more than 90 degrees away
    from the heading just before and just after the run."""
    longest = max(1, int(round(BRIEF_S * fps)))
    count, t, T = 0, 1, len(heading)
    while t < T - 1:
        if not np.isfinite(heading[t - 1]):
            t += 1
            continue
        end = t
        while end < T and np.isfinite(heading[end]) and turn_between(heading[end], heading[t - 1]) > 90.0:
            end += 1
        run = end - t
        if 0 < run <= longest and end < T and np.isfinite(heading[end]):
            if turn_between(heading[end], heading[t - 1]) < 45.0:
                count += run
        t = max(end, t + 1)
    return count


def swapped_share(motions: np.ndarray, keypoints: np.ndarray, camera, joints: tuple[int, ...]) -> float:
    """Share of the frames of motions ``(K, T, 17, 3)`` whose ``joints``, projected, lie closer to the other side's
    keypoints ``(T, 17, 3)`` than to their own (see the module)."""
    seen = (keypoints[:, joints, 2] > 0).all(axis=1)  # (T,)
    present = np.isfinite(motions).all(axis=(2, 3)) & seen[None]
    if not present.any():
        return 0.0
    pixels = project(np.nan_to_num(motions[:, :, joints]), camera)  # (K, T, J, 2)
    own = np.linalg.norm(pixels - keypoints[None, :, joints, :2], axis=-1).mean(axis=-1)
    other = np.linalg.norm(pixels - keypoints[None, :, [MIRROR[j] for j in joints], :2], axis=-1).mean(axis=-1)
    swapped = (other < 0.5 * own) & (own - other > 10.0)
    return float(swapped[present].mean())


def person_row(path: Path, result, p: int) -> str | None:
    """The table row of person ``p`` of one lift, or None if present in under half its frames."""
    hyps = np.asarray(result.hypotheses[p], np.float64)
    answer = np.asarray(result.median[p], np.float64)[None]
    present = np.isfinite(answer[0]).all(axis=(1, 2))
    if present.mean() < 0.5:
        return None
    view = int(np.argmax((result.keypoints2d[:, p, :, :, 2] > 0).sum(axis=(1, 2))))
    kp, camera = repair_side_swaps(result.keypoints2d[view, p][:, None])[0][:, 0], result.cameras[view]
    brief = sum(brief_turn_frames(h, result.fps) for h in headings(hyps))
    cells = [
        f"{path.stem} p{int(result.track_ids[p])}",
        f"{100 * turn_share(hyps):.2f} % / {100 * turn_share(answer):.2f} %",
        f"{1000 * brief / max(1, np.isfinite(hyps).all(axis=(2, 3)).sum()):.1f}",
        f"{100 * swapped_share(hyps, kp, camera, LEGS):.2f} % / {100 * swapped_share(answer, kp, camera, LEGS):.2f} %",
        f"{100 * swapped_share(hyps, kp, camera, ARMS):.2f} % / {100 * swapped_share(answer, kp, camera, ARMS):.2f} %",
    ]
    return "| " + " | ".join(cells) + " |"


def main() -> None:
    """Print the table for the npz files given."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("npz", nargs="+", type=Path)
    args = parser.parse_args()
    print("| lift, person | turns >60 (hyps / answer) | brief turns per 1000 | swapped legs | swapped arms |")
    print("|---|---|---|---|---|")
    for path in args.npz:
        result = read_npz(path)
        for p in range(result.num_persons):
            row = person_row(path, result, p)
            if row:
                print(row)


if __name__ == "__main__":
    main()
