"""Figures of the user-facing outputs of lifted npz files: BVH faithfulness, TRC/C3D read-back, joint angles.

    python tools/output_figures.py OUT/clip/clip.npz [...] --work /tmp/figures

For each npz and person: the BVH of the median (fit error mean / max, largest frame-to-frame
change of any joint's local rotation, largest head-bone angle to the npz, largest bone stretch of
the motion itself, half of which bounds any rigid skeleton's largest error from below, and the
largest frame-to-frame turn of any of its bones, for comparison); the
TRC (read as text) and C3D (read by ezc3d) against the npz on present frames; per joint angle the
median over frames of the median motion's angle and of the 5-95 % band width.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import ezc3d
import numpy as np

from platypose.exporters.angles import ANGLE_NAMES, angle_series
from platypose.exporters.export import export
from platypose.exporters.npz import read_npz
from platypose.lifting.skeleton import BONES


def largest_bone_turn(joints: np.ndarray) -> float:
    """Largest angle (degrees) any bone turns between consecutive present frames of joints (T, 17, 3)."""
    on = np.isfinite(joints).all(axis=(1, 2))
    bones = np.stack([joints[:, c] - joints[:, p] for c, p in BONES], axis=1)
    bones /= np.linalg.norm(bones, axis=-1, keepdims=True)
    both = on[1:] & on[:-1]
    cos = np.clip(np.sum(bones[1:] * bones[:-1], -1)[both], -1, 1)
    return float(np.degrees(np.arccos(cos)).max(initial=0.0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("npz", nargs="+", type=Path)
    parser.add_argument("--work", type=Path, default=Path("/tmp/output-figures"))
    args = parser.parse_args()
    for path in args.npz:
        result = read_npz(path)
        out = args.work / path.stem
        export(result, out, path.stem, ["npz", "bvh", "trc", "c3d"])
        fits = read_npz(out / f"{path.stem}.npz").meta["bvh_fit_error"]
        series = angle_series(result)
        print(f"== {path} ({result.num_persons} persons, {result.num_frames} frames, {len(result.cameras)} cameras)")
        for p, track in enumerate(result.track_ids):
            fit = fits.get(f"p{track}", {}).get("median")
            if fit is None:
                continue
            med = np.asarray(result.median[p], np.float64)
            on = np.isfinite(med).all(axis=(1, 2))
            print(
                f"p{track}: BVH fit {1000 * fit['mean_m']:.1f} mm mean / {1000 * fit['max_m']:.1f} mm max, "
                f"largest rotation step {fit['step_deg']:.1f} deg (motion's own largest bone turn "
                f"{largest_bone_turn(med):.1f} deg), head vs npz {fit['head_deg']:.4f} deg, "
                f"bone stretch of the motion up to {1000 * fit['stretch_m']:.0f} mm "
                f"(so no rigid skeleton's max error is below {500 * fit['stretch_m']:.0f} mm)"
            )
            lines = (out / f"{path.stem}_p{track}.trc").read_text().split("\n")[5:]
            trc = np.array([[float(v) for v in line.split("\t")] for line in lines if line.strip()])
            trc_xyz = trc[:, 2:].reshape(len(trc), 17, 3)[:, :, [2, 0, 1]]  # back to Z up
            c3d = ezc3d.c3d(str(out / f"{path.stem}_p{track}.c3d"))["data"]["points"][:3]
            c3d_xyz = np.moveaxis(c3d, 0, -1).transpose(1, 0, 2)[:, :, [2, 0, 1]] / 1000
            print(
                f"     TRC vs npz max {np.abs(trc_xyz[on] - med[on]).max():.2e} m, "
                f"C3D vs npz max {np.abs(c3d_xyz[on] - med[on]).max():.2e} m, "
                f"no NaN: {np.isfinite(trc).all() and np.isfinite(c3d).all()}, filled frames {int((~on).sum())}"
            )
            s = series[p][on]
            parts = [
                f"{n} {np.median(s[:, a, 0]):.0f} [{np.median(s[:, a, 3] - s[:, a, 1]):.0f}]"
                for a, n in enumerate(ANGLE_NAMES)
            ]
            print("     angles, median over frames [median 5-95 % band]: " + ", ".join(parts))


if __name__ == "__main__":
    main()
