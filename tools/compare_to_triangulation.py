"""Compare lifts of a multi-view take with a plain triangulation of its 2D keypoints.

    .venv/bin/python tools/compare_to_triangulation.py OUT/all/<job>/<job>.npz OUT/cam01/<job>/<job>.npz ...

Detection caches (``*.detections.npz``, written beside lifts from video) are skipped, so globs such
as ``OUT/*/*/*.npz`` work.

The first npz must be a lift from several views: its 2D keypoints (all views, person 0)
are triangulated with its cameras (DLT, ``lifting.triangulation.triangulate``) and that
is the reference. Every npz given (the first included) is then compared with it, frame
by frame where the reference has all 17 joints, and printed as a Markdown table row:

- median vs triangulation: mean / median over joints and frames of the distance from
  the hypotheses' median to the reference (mm); and the pelvis alone;
- median vs rigid triangulation: the same against the reference made rigid as a lift is
  (``lifting.finish.rigid``: one length per bone, one shape per body over the clip): a person is rigid, a
  triangulation of detected keypoints is not (its bones stretch by centimetres), and a rigid lift
  cannot follow that stretch;
- best hypothesis per joint: for each joint and frame the nearest hypothesis (mm, mean);
- hip-centred best hypothesis per frame: per frame the hypothesis whose pelvis-relative joints are nearest the
  reference's (mean over joints), mean over frames (mm);
- hip-centred median: the exported single answer's pelvis-relative joints against the reference's (mm, mean);
- inside box: share of reference joints inside the hypotheses' per-axis min-max box; and of the 12 limb
  joints (hips, knees, ankles, shoulders, elbows, wrists) inside the min-max box and inside the per-axis
  5-95 % band;
- pelvis depth: 5 / 50 / 95 % of the hypotheses' pelvis depth from the first camera
  of the lift against the reference's median depth, and the share of frames whose
  reference depth lies within the hypotheses' 5-95 % range;
- under floor: share of hypothesis-frames whose lowest ankle is more than 3 cm under the calibration's floor
  z = 0 (the reference's own lowest ankle, median over frames, in brackets).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from platypose.exporters.npz import read_npz
from platypose.lifting.calibration.matching import align_frames
from platypose.lifting.finish.rigid import rigid_paths
from platypose.lifting.finish.rigid_shape import clip_shape
from platypose.lifting.skeleton import JOINT_INDEX
from platypose.lifting.triangulation import triangulate

LIMB_NAMES = ("hip", "knee", "ankle", "shoulder", "elbow", "wrist")


def reference_joints(path: Path) -> np.ndarray:
    """Triangulated joints ``(T, 17, 3)`` of person 0 from all views of the lift ``path``; NaN where not seen twice."""
    result = read_npz(path)
    if len(result.cameras) < 2:
        raise SystemExit(f"{path}: the reference lift must have several views, it has {len(result.cameras)}")
    keypoints = np.asarray(result.keypoints2d)[:, 0]  # (C, T, 17, 3)
    confidence = np.nan_to_num(keypoints[..., 2])
    points = triangulate(np.nan_to_num(keypoints[..., :2]), confidence, result.cameras)
    seen = (confidence > 0).sum(0) >= 2
    return np.where(seen[..., None], points, np.nan)


def rigid_reference(path: Path, reference: np.ndarray) -> np.ndarray:
    """``reference`` ``(T, 17, 3)`` made rigid (``lifting.finish.rigid.rigid_paths``) with the views of the lift ``path``."""
    result = read_npz(path)
    seen = np.moveaxis(np.nan_to_num(np.asarray(result.keypoints2d)[:, 0, ..., 2]) > 0, 0, -1)  # (T, 17, C)
    centres = np.stack([cam.center for cam in result.cameras])
    return rigid_paths(reference[None], clip_shape(reference[None]), centres, seen, result.fps)[0]


def at_times(reference: np.ndarray, reference_times: np.ndarray, times: np.ndarray) -> np.ndarray:
    """``reference`` ``(T, ...)`` at ``times`` (a lift of every N-th frame, ``--stride N``): the frame within half a
    reference frame of each, NaN where none is."""
    step = np.median(np.diff(reference_times)) if len(reference_times) > 1 else np.inf
    index = align_frames(times, reference_times, 0.5 * step)
    return np.where((index >= 0)[(...,) + (None,) * (reference.ndim - 1)], reference[index], np.nan)


def compare(path: Path, reference: np.ndarray, rigid: np.ndarray, reference_times: np.ndarray) -> str:
    """One Markdown row of figures for the lift ``path`` against ``reference`` ``(T, 17, 3)`` and its ``rigid`` one,
    both at ``reference_times`` (T,), paired with the lift's frames by time."""
    result = read_npz(path)
    if len(result.frame_times) != len(reference_times) or not np.allclose(result.frame_times, reference_times):
        reference = at_times(reference, reference_times, np.asarray(result.frame_times))
        rigid = at_times(rigid, reference_times, np.asarray(result.frame_times))
    hyps = np.asarray(result.hypotheses)[0].astype(np.float64)  # (N, T, 17, 3)
    median = np.asarray(result.median)[0].astype(np.float64)
    frames = np.isfinite(reference).all(axis=(-1, -2)) & np.isfinite(hyps).all(axis=(0, -1, -2))
    ref, hyps, median = reference[frames], hyps[:, frames], median[frames]
    to_median = np.linalg.norm(median - ref, axis=-1) * 1000
    to_rigid = np.linalg.norm(median - rigid[frames], axis=-1) * 1000
    best = np.linalg.norm(hyps - ref, axis=-1).min(axis=0) * 1000
    inside = ((hyps.min(0) <= ref) & (ref <= hyps.max(0))).all(-1).mean()
    limbs = [JOINT_INDEX[f"{side}_{joint}"] for side in ("left", "right") for joint in LIMB_NAMES]
    limb_range = ((hyps.min(0) <= ref) & (ref <= hyps.max(0))).all(-1)[:, limbs].mean()
    band_low, band_high = np.percentile(hyps, [5, 95], axis=0)
    limb_band = ((band_low <= ref) & (ref <= band_high)).all(-1)[:, limbs].mean()
    answer = np.linalg.norm((median - median[:, :1]) - (ref - ref[:, :1]), axis=-1).mean() * 1000
    cam = result.cameras[0]
    depth = (hyps[..., 0, :] @ cam.R.T + cam.t)[..., 2]  # (N, T') pelvis depth from the first camera
    ref_depth = (ref[:, 0] @ cam.R.T + cam.t)[:, 2]
    low, mid, high = np.percentile(depth, [5, 50, 95])
    lo_t, hi_t = np.percentile(depth, [5, 95], axis=0)
    within = ((lo_t <= ref_depth) & (ref_depth <= hi_t)).mean()
    centred = np.linalg.norm((hyps - hyps[..., :1, :]) - (ref - ref[:, :1])[None], axis=-1).mean(-1) * 1000
    lowest = hyps[..., [3, 6], 2].min(-1)  # (N, T') lowest ankle height
    ref_lowest = np.median(ref[:, [3, 6], 2].min(-1))
    return (
        f"| {path.parent.parent.name} ({len(result.cameras)} view(s), {hyps.shape[0]} hypotheses, {frames.sum()} frames) "
        f"| {to_median.mean():.1f} / {np.median(to_median):.1f} mm | {to_rigid.mean():.1f} mm "
        f"| {to_median[:, 0].mean():.1f} mm "
        f"| {best.mean():.1f} mm | {centred.min(axis=0).mean():.1f} mm | {answer:.1f} mm "
        f"| {100 * inside:.0f} % / {100 * limb_range:.0f} % / {100 * limb_band:.0f} % "
        f"| {low:.2f} / {mid:.2f} / {high:.2f} m vs {np.median(ref_depth):.2f} m ({100 * within:.0f} % of frames inside) "
        f"| {100 * np.mean(lowest < -0.03):.1f} % ({100 * ref_lowest:.0f} cm) |"
    )


def rigid_gap(reference: np.ndarray, rigid: np.ndarray) -> float:
    """Mean distance (mm) between the reference and its rigid version over frames where it has every joint."""
    frames = np.isfinite(reference).all(axis=(-1, -2))
    return float(np.linalg.norm(reference[frames] - rigid[frames], axis=-1).mean() * 1000)


def main() -> None:
    """Parse the lifts, triangulate the first one's keypoints, print one row per lift."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("lifts", nargs="+", type=Path, help="npz files; the first is a multi-view lift")
    args = parser.parse_args()
    lifts = [path for path in args.lifts if not path.name.endswith(".detections.npz")]  # a glob's detection caches
    reference = reference_joints(lifts[0])
    rigid = rigid_reference(lifts[0], reference)
    print(f"The rigid triangulation lies {rigid_gap(reference, rigid):.1f} mm (mean) from the triangulation.\n")
    print(
        "| lift | median vs triangulation (mean / median) | median vs rigid triangulation | pelvis "
        "| best hypothesis per joint "
        "| hip-centred best hypothesis per frame | hip-centred median "
        "| inside min-max box: all / limb joints; limb joints inside 5-95 % | pelvis depth 5 / 50 / 95 % "
        "| lowest ankle under -3 cm (reference's) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for path in lifts:
        print(compare(path, reference, rigid, np.asarray(read_npz(lifts[0]).frame_times)))


if __name__ == "__main__":
    main()
