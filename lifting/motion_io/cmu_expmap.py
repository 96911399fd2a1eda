"""CMU mocap as exponential maps (the motion-prediction text files: 117 comma-separated values a frame).

Each row holds the root position (3 values, ASF length units) and one exponential map per joint of the
38-joint CMU skeleton (root first), 120 frames per second, Y up. The format was made popular by the
CMU subset of human motion prediction work (basketball, running, soccer, walking, ...). The skeleton,
its bone vectors and the composition rule are fixed by that format (the CMU ASF of the subject the
data was retargeted to): ``p_j = o_j R_parent + p_parent`` and ``R_j = exp(r_j) R_parent`` with row
vectors, ``o_j`` the bone vector from the parent's point to point ``j``. One ASF unit is ``1 / 0.45`` inches.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import CMU_ASF_RECIPE, apply_recipe
from platypose.lifting.motion import Motion
from platypose.lifting.motion_io.kinematics import y_up_to_z_up

DEFAULT_FPS = 120.0
METRES_PER_UNIT = 0.0254 / 0.45
VALUES_PER_FRAME = 117

# The 38 points, each named after the CMU ASF bone that ends there ("_start": a bone's start, where it has
# no length before it); the rotation of a point's frame turns the bone vectors of its children.
JOINTS: tuple[str, ...] = (
    "root",
    "lhipjoint_start",
    "lhipjoint",
    "lfemur",
    "ltibia",
    "lfoot",
    "ltoes",
    "rhipjoint_start",
    "rhipjoint",
    "rfemur",
    "rtibia",
    "rfoot",
    "rtoes",
    "lowerback_start",
    "lowerback",
    "upperback",
    "thorax",
    "lowerneck",
    "upperneck",
    "head",
    "lclavicle_start",
    "lclavicle",
    "lhumerus",
    "lradius",
    "lwrist",
    "lhand",
    "lfingers",
    "lthumb_start",
    "lthumb",
    "rclavicle_start",
    "rclavicle",
    "rhumerus",
    "rradius",
    "rwrist",
    "rhand",
    "rfingers",
    "rthumb_start",
    "rthumb",
)
PARENTS: tuple[int, ...] = (
    -1, 0, 1, 2, 3, 4, 5, 0, 7, 8, 9, 10, 11, 0, 13, 14, 15, 16, 17, 18,
    15, 20, 21, 22, 23, 24, 25, 23, 27, 15, 29, 30, 31, 32, 33, 34, 32, 36,
)  # fmt: skip
# Bone vectors in ASF units, in the parent's frame at rest (x to the subject's left, y up).
OFFSETS = np.array(
    [
        [0, 0, 0],
        [0, 0, 0],
        [1.65674, -1.80282, 0.62477],
        [2.5972, -7.13576, 0],
        [2.49236, -6.8477, 0],
        [0.19704, -0.54136, 2.14581],
        [0, 0, 1.11249],
        [0, 0, 0],
        [-1.6107, -1.80282, 0.62476],
        [-2.59502, -7.12977, 0],
        [-2.4678, -6.78024, 0],
        [-0.23024, -0.63258, 2.13368],
        [0, 0, 1.11569],
        [0, 0, 0],
        [0.01961, 2.0545, -0.14112],
        [0.01021, 2.06436, -0.05921],
        [0, 0, 0],
        [0.00713, 1.56711, 0.14968],
        [0.03429, 1.56041, -0.10006],
        [0.01305, 1.6256, -0.05265],
        [0, 0, 0],
        [3.54205, 0.90436, -0.17364],
        [4.86513, 0, 0],
        [3.35554, 0, 0],
        [0, 0, 0],
        [0.66117, 0, 0],
        [0.53306, 0, 0],
        [0, 0, 0],
        [0.5412, 0, 0.5412],
        [0, 0, 0],
        [-3.49802, 0.75994, -0.32616],
        [-5.02649, 0, 0],
        [-3.36431, 0, 0],
        [0, 0, 0],
        [-0.73041, 0, 0],
        [-0.58887, 0, 0],
        [0, 0, 0],
        [-0.59786, 0, 0.59786],
    ]
)


def is_cmu_expmap(path: Path) -> bool:
    """Whether a text file's first line is 117 comma-separated numbers."""
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            first = handle.readline(1 << 16)
        return len([float(v) for v in first.split(",")]) == VALUES_PER_FRAME
    except (OSError, ValueError):
        return False


def expmap_points(values: np.ndarray) -> np.ndarray:
    """The 38 points ``(T, 38, 3)`` in ASF units, Y up, from rows of root position + 38 exponential maps."""
    frames = values.shape[0]
    rotations = Rotation.from_rotvec(values[:, 3:].reshape(-1, 3)).as_matrix().reshape(frames, len(JOINTS), 3, 3)
    points = np.zeros((frames, len(JOINTS), 3))
    frames_of = np.zeros((frames, len(JOINTS), 3, 3))
    for joint, parent in enumerate(PARENTS):
        if parent < 0:
            points[:, joint] = OFFSETS[joint] + values[:, :3]
            frames_of[:, joint] = rotations[:, joint]
            continue
        points[:, joint] = np.einsum("c,tcd->td", OFFSETS[joint], frames_of[:, parent]) + points[:, parent]
        frames_of[:, joint] = rotations[:, joint] @ frames_of[:, parent]
    return points


def load_cmu_expmap(path: Path, fps: float | None = None) -> list[Motion]:
    """One clip from a CMU exponential-map text file (120 fps unless ``fps`` says otherwise)."""
    try:
        values = np.loadtxt(path, delimiter=",", ndmin=2)
    except (OSError, ValueError) as err:
        raise InputError(f"{path}: not a CMU exponential-map file ({err})") from None
    if values.shape[1] != VALUES_PER_FRAME or values.shape[0] == 0:
        raise InputError(f"{path}: expected rows of {VALUES_PER_FRAME} values, got {values.shape}")
    if not np.isfinite(values).all():
        raise InputError(f"{path}: frame {int(np.argmin(np.isfinite(values).all(axis=1)))} holds NaN or inf")
    points = y_up_to_z_up(expmap_points(values) * METRES_PER_UNIT)
    joints = apply_recipe(points, list(JOINTS), CMU_ASF_RECIPE)
    return [Motion(joints=joints, fps=fps or DEFAULT_FPS, name=path.stem, extra={"format": "cmu_expmap"})]
