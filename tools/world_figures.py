"""Per person of lifts: where they stand and lean in the lift's world, and how far their pelvis travels.

    .venv/bin/python tools/world_figures.py OUT/<name>/<name>.npz ...

For each npz and person (the median motion, the frames the person is present):

- lowest ankle: the lower ankle's z (the height above the floor in a calibrated or estimated world), median over
  frames, and its 10th percentile; its median in each whole second of the take, and how far those medians
  spread (largest less smallest: the floor's check, at most 8 cm along a walker's path);
- trunk tilt: the angle of pelvis -> thorax from world z up, median over frames (degrees);
- pelvis z: median over frames;
- pelvis path: the summed pelvis steps between consecutive present frames (m), the largest step (m), and the
  largest step from the last frame before a gap (absent frames) to the first after it (m);
- the world the npz says (``meta["floor"]``: source and frame).

Printed as Markdown table rows.
"""

from __future__ import annotations

import sys

import numpy as np

from platypose.exporters.npz import read_npz


def person_figures(median: np.ndarray, times: np.ndarray) -> dict:
    """Figures of one median motion ``(T, 17, 3)`` (NaN where absent) on ``times`` (T,) seconds."""
    on = np.isfinite(median).all(axis=(1, 2))
    joints = median[on].astype(np.float64)
    lowest = joints[:, [3, 6], 2].min(axis=1)
    trunk = joints[:, 8] - joints[:, 0]
    tilt = np.degrees(np.arccos(np.clip(trunk[:, 2] / np.linalg.norm(trunk, axis=1), -1, 1)))
    frames = np.flatnonzero(on)
    second = np.floor(times[on] - times[0]).astype(int)
    per_second = [np.median(lowest[second == s]) for s in np.unique(second)]
    pelvis = median[:, 0].astype(np.float64)
    consecutive = frames[1:][np.diff(frames) == 1]
    steps = np.linalg.norm(pelvis[consecutive] - pelvis[consecutive - 1], axis=1)
    across = np.linalg.norm(np.diff(pelvis[frames], axis=0), axis=1)[np.diff(frames) > 1]  # over absent frames
    return {
        "frames": int(on.sum()),
        "lowest_ankle_m": float(np.median(lowest)),
        "lowest_ankle_p10_m": float(np.percentile(lowest, 10)),
        "lowest_per_second_spread_m": float(np.ptp(per_second)),
        "trunk_tilt_deg": float(np.median(tilt)),
        "pelvis_z_m": float(np.median(joints[:, 0, 2])),
        "path_m": float(steps.sum()),
        "max_step_m": float(steps.max()) if len(steps) else 0.0,
        "gap_step_m": float(across.max()) if len(across) else 0.0,
    }


def main(paths: list[str]) -> None:
    head = (
        "| npz | person | frames | lowest ankle median (p10) | its per-second medians spread | trunk tilt | pelvis z "
    )
    print(head + "| pelvis path | max step | step over a gap | world |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for path in paths:
        result = read_npz(path)
        floor = (result.meta or {}).get("floor") or {}
        world = floor.get("source", "none") + (" (estimated world)" if floor.get("frame") else "")
        for p, track in enumerate(result.track_ids):
            f = person_figures(np.asarray(result.median[p]), np.asarray(result.frame_times))
            print(
                f"| {path} | {track} | {f['frames']} | {100 * f['lowest_ankle_m']:.1f} cm ({100 * f['lowest_ankle_p10_m']:.1f}) "
                f"| {100 * f['lowest_per_second_spread_m']:.1f} cm "
                f"| {f['trunk_tilt_deg']:.1f} deg | {f['pelvis_z_m']:.2f} m | {f['path_m']:.1f} m | {f['max_step_m']:.2f} m "
                f"| {f['gap_step_m']:.2f} m | {world} |"
            )


if __name__ == "__main__":
    main(sys.argv[1:])
