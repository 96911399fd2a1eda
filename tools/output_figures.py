"""Figures of the user-facing outputs of lifted npz files: BVH faithfulness, TRC/C3D read-back, joint angles.

    python tools/output_figures.py OUT/clip/clip.npz [...] --work /tmp/figures

For each npz and person: the BVH of the median (fit error mean / max, largest frame-to-frame
change of any joint's local rotation, largest head-bone angle to the npz, largest bone stretch of
the motion itself, half of which bounds any rigid skeleton's largest error from below, and the
largest frame-to-frame turn of any of its bones, for comparison; how many
frame-to-frame joint steps exceed 45 degrees, a roll pop on a skinned character, over the
present frames: all joints, the arms' shoulders and elbows, the legs' hips and knees; and how
many frames of a bent knee or elbow bend backwards about the BVH's hinge axis, or off it); the
TRC (read as text) and C3D (read by ezc3d) against the npz on present frames; per joint angle the
median over frames of the median motion's angle and of the 5-95 % band width.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import ezc3d
import numpy as np

from platypose.exporters.angles import ANGLE_NAMES, angle_series
from platypose.exporters.bvh import fit_skeleton, motion_channels, to_bvh_axes
from platypose.exporters.export import export
from platypose.exporters.ik import hinge_alignment, joint_steps
from platypose.exporters.npz import read_npz
from platypose.lifting.skeleton import BONES, JOINT_NAMES

POP_DEG, BENT_DEG, OFF_DEG = 45.0, 30.0, 30.0
ARMS = [JOINT_NAMES.index(n) for n in ("left_shoulder", "left_elbow", "right_shoulder", "right_elbow")]
LEGS = [JOINT_NAMES.index(n) for n in ("right_hip", "right_knee", "left_hip", "left_knee")]


def largest_bone_turn(joints: np.ndarray) -> float:
    """Largest angle (degrees) any bone turns between consecutive present frames of joints (T, 17, 3)."""
    on = np.isfinite(joints).all(axis=(1, 2))
    bones = np.stack([joints[:, c] - joints[:, p] for c, p in BONES], axis=1)
    bones /= np.linalg.norm(bones, axis=-1, keepdims=True)
    both = on[1:] & on[:-1]
    cos = np.clip(np.sum(bones[1:] * bones[:-1], -1)[both], -1, 1)
    return float(np.degrees(np.arccos(cos)).max(initial=0.0))


def pops(joints: np.ndarray) -> str:
    """How the BVH of the present frames of joints (T, 17, 3) turns its joints: steps over POP_DEG (all, arms, legs),
    the largest arm step, and how many frames of a clearly bent limb (over BENT_DEG) bend backwards about its
    hinge axis or off it by over OFF_DEG (a knee or elbow bending the wrong way or sideways on a skinned character)."""
    present = np.asarray(joints[np.isfinite(joints).all(axis=(1, 2))], np.float64)
    offsets = fit_skeleton(present, np.ones(len(present), bool))
    rot = motion_channels(present, offsets)[1]
    steps = joint_steps(rot)
    t, j = np.unravel_index(steps[:, ARMS].argmax(), steps[:, ARMS].shape)
    bend, cos = hinge_alignment(rot, to_bvh_axes(present), offsets)
    cos = cos[bend > BENT_DEG]
    bent, backwards, off = cos.size, int((cos < 0).sum()), int((np.abs(cos) < np.cos(np.radians(OFF_DEG))).sum())
    return (
        f"joint steps over {POP_DEG:.0f} deg: {int((steps > POP_DEG).sum())} (arms {int((steps[:, ARMS] > POP_DEG).sum())}, "
        f"legs {int((steps[:, LEGS] > POP_DEG).sum())}), largest arm step {steps[t, ARMS[j]]:.1f} deg "
        f"({JOINT_NAMES[ARMS[j]]}, present frames {t}-{t + 1}); of {bent} limb-frames bent over {BENT_DEG:.0f} deg, "
        f"{backwards} bend backwards about the hinge axis, {off} over {OFF_DEG:.0f} deg off it"
    )


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
            print(f"     {pops(med)}")
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
