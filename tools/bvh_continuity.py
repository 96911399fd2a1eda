"""How continuous a lift's BVH files are: per person, written from the npz median and read back by PyPI ``bvh``.

    python tools/bvh_continuity.py OUT/clip/clip.npz [more.npz ...]

Prints, per person: present frames, the fit (mean and largest joint distance to the npz, on present
frames), the largest local joint turn between consecutive frames (geodesic angle of each joint's local
rotation as the file's channels give it) where none of the npz's own bone directions turns over 30
degrees, the frames where that turn is over 45 degrees, and the root's largest step between frames.
"""

import sys
import tempfile
from pathlib import Path

import numpy as np
from bvh import Bvh

from platypose.exporters.bvh import write_bvh
from platypose.exporters.euler import euler_to_matrix
from platypose.exporters.frames import Lead
from platypose.exporters.npz import read_npz
from platypose.lifting.skeleton import BONES, JOINT_NAMES, NUM_JOINTS


def bone_turns(joints: np.ndarray) -> np.ndarray:
    """Largest turn (T - 1,) in degrees of any bone's direction between consecutive frames (NaN where absent)."""
    d = np.stack([joints[:, c] - joints[:, p] for c, p in BONES], 1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip((d[1:] * d[:-1]).sum(-1), -1, 1))).max(axis=1)


for npz in sys.argv[1:]:
    result = read_npz(npz)
    for p, track in enumerate(result.track_ids):
        median = np.asarray(result.median[p], np.float64)
        present = np.isfinite(median).all(axis=(1, 2))
        if not present.any():
            continue
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "p.bvh"
            fit = write_bvh(Lead(result.median, p), result.fps, path, result.frame_times)
            values = np.array(Bvh(path.read_text()).frames, np.float64)
        local = euler_to_matrix(values[:, 3:].reshape(len(values), NUM_JOINTS, 3))
        rel = np.swapaxes(local[:-1], -1, -2) @ local[1:]
        steps = np.degrees(np.arccos(np.clip((np.trace(rel, axis1=-2, axis2=-1) - 1) / 2, -1, 1)))
        calm = present[1:] & present[:-1] & (np.nan_to_num(bone_turns(median), nan=180.0) <= 30.0)
        worst = steps.max(axis=1)
        over = np.flatnonzero(calm & (worst > 45.0))
        where = ", ".join(f"{t}-{t + 1} {JOINT_NAMES[steps[t].argmax()]} {worst[t]:.0f}" for t in over[:5])
        root = np.linalg.norm(np.diff(values[:, :3], axis=0), axis=1).max() / 100.0
        print(
            f"{Path(npz).name} p{track}: {present.sum()}/{len(present)} frames present; fit mean "
            f"{1000 * fit.mean_m:.2f} mm, max {1000 * fit.max_m:.2f} mm; largest joint turn where bones turn <= 30 deg: "
            f"{worst[calm].max(initial=0.0):.1f} deg; over 45: {len(over)} ({where}); root step max {root:.2f} m"
        )
