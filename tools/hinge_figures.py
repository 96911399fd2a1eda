"""Print figures of lifts: hinges bent backwards, their fastest turn, OpenSim IK against the angles CSV.

    .venv/bin/python tools/hinge_figures.py OUT/<job>/<job>.npz ...

Per person present in at least half the frames of each npz, one Markdown table row:

- knees back >10: share of the exported answer's present frames (``median``) with a knee's signed flexion
  (:func:`lifting.anatomy.hinges.signed_flexion`) under -10 degrees, the larger of the two knees; and the same share of
  hypothesis-frames; elbows back >10: the same for the elbows (answer / hypotheses);
- fastest hinge: the largest change of a knee's or an elbow's signed flexion between two consecutive present frames
  of the answer, in degrees per second (with the hinge and the frame); a sign change counts as the bend between;
  and of its size alone (the unsigned angle, which a sign change at a large bend does not move);
- IK at limit: where ``<job>_p<track>.mot`` lies beside the npz, the largest share over the four hinge coordinates
  of frames within 1 degree of an end of their range (-20, 170); marker RMS (median, cm) from the npz's meta;
- CSV vs mot: where ``<job>_angles.csv`` lies beside it too, the largest over the four hinges of the median absolute
  difference between the CSV's ``median_deg`` and the ``.mot`` coordinate (degrees).
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from platypose.exporters.mot import at_limit_shares, read_storage
from platypose.exporters.npz import read_npz
from platypose.exporters.opensim_model import HINGE_COORDINATES
from platypose.lifting.anatomy.hinges import HINGE_NAMES, signed_flexion

BACK_DEG = 10.0


def _csv_hinges(path: Path, track: int, frames: int) -> np.ndarray:
    """The angles CSV's ``median_deg`` of the four hinges of person ``track``, ``(frames, 4)`` (NaN where absent)."""
    out = np.full((frames, len(HINGE_NAMES)), np.nan)
    columns = {f"{name}_flexion": k for k, name in enumerate(HINGE_NAMES)}
    with path.open() as f:
        for row in csv.DictReader(f):
            if int(row["person"]) == track and row["angle"] in columns:
                out[int(row["frame"]), columns[row["angle"]]] = float(row["median_deg"])
    return out


def person_row(path: Path, p: int) -> str | None:
    """The table row of person index ``p`` of the lift ``path``, or None if present in under half the frames."""
    result = read_npz(path)
    present = result.present()[p]
    if present.mean() < 0.5:
        return None
    track = int(result.track_ids[p])
    answer = signed_flexion(np.asarray(result.median[p], np.float64)[present])  # (t, 4)
    hyps = signed_flexion(np.asarray(result.hypotheses[p], np.float64)[:, present])  # (N, t, 4)
    back = answer < -BACK_DEG
    hyp_back = hyps < -BACK_DEG
    times = np.asarray(result.frame_times)[present]
    frames = np.flatnonzero(present)
    consecutive = np.diff(frames) == 1
    dt = np.diff(times)[:, None]
    rates = np.where(consecutive[:, None], np.abs(np.diff(answer, axis=0)) / dt, 0.0)
    sizes = np.where(consecutive[:, None], np.abs(np.diff(np.abs(answer), axis=0)) / dt, 0.0)
    t, h = np.unravel_index(np.argmax(rates), rates.shape)
    ts, hs = np.unravel_index(np.argmax(sizes), sizes.shape)
    cells = [
        f"{path.parent.parent.name}/{path.stem}",
        f"p{track}",
        f"{back[:, :2].mean(0).max():.1%} / {hyp_back[..., :2].mean((0, 1)).max():.1%}",
        f"{back[:, 2:].mean(0).max():.1%} / {hyp_back[..., 2:].mean((0, 1)).max():.1%}",
        f"{rates[t, h]:.0f} ({HINGE_NAMES[h]}, frame {frames[t + 1]})",
        f"{sizes[ts, hs]:.0f} ({HINGE_NAMES[hs]}, frame {frames[ts + 1]})",
    ]
    mot = path.parent / f"{path.stem}_p{track}.mot"
    if mot.exists():
        names, values = read_storage(mot)
        shares = at_limit_shares(names, values)
        worst = max(shares, key=shares.get)
        rms = result.meta.get("opensim_ik", {}).get(f"p{track}", {}).get("marker_rms_median_m", float("nan"))
        cells += [f"{shares[worst]:.0%} ({worst})", f"{100 * rms:.1f}"]
        angles = path.parent / f"{path.stem}_angles.csv"
        if angles.exists():
            ours = _csv_hinges(angles, track, result.num_frames)
            theirs = np.stack([values[:, names.index(c)] for c in HINGE_COORDINATES], -1)
            rows = np.isfinite(ours).all(-1)
            diff = np.median(np.abs(ours[rows] - theirs[: result.num_frames][rows]), axis=0)
            cells.append(f"{diff.max():.1f} ({HINGE_COORDINATES[int(np.argmax(diff))]})")
    return "| " + " | ".join(cells) + " |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("npz", nargs="+", type=Path)
    args = parser.parse_args()
    print(
        "| lift | person | knees back >10: answer / hyp. | elbows back >10: answer / hyp. | fastest hinge (deg/s) "
        "| fastest size (deg/s) | IK at limit | marker RMS (cm) | CSV vs mot (deg) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for path in args.npz:
        if path.name.endswith(".detections.npz"):
            continue
        for p in range(read_npz(path).num_persons):
            row = person_row(path, p)
            if row is not None:
                print(row)


if __name__ == "__main__":
    main()
