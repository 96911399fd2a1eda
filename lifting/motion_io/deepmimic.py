"""DeepMimic humanoid clips (JSON ``Frames`` of root pose + joint rotations), by forward kinematics over its URDF.

A frame is ``[duration, root xyz (3), root quat (4), then per joint in
CHANNEL_ORDER a quaternion (4, spherical) or an angle (1, revolute)]``,
quaternions ``(w, x, y, z)``, Y up. The pybullet ``humanoid.urdf`` is drawn 4x
too large and loaded with ``globalScaling=0.25``; root positions are in metres.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import DEEPMIMIC_RECIPE, apply_recipe
from platypose.lifting.motion import Motion
from platypose.lifting.motion_io.kinematics import forward_kinematics, rate_from_step, y_up_to_z_up
from platypose.lifting.timebase import interpolate

URDF_NAME = "humanoid.urdf"
URDF_SCALE = 0.25
ROOT_LINK = "root"
HEAD_LINK = "neck"  # the link whose collision sphere is the head
CHANNEL_ORDER: tuple[str, ...] = (
    "chest",
    "neck",
    "right_hip",
    "right_knee",
    "right_ankle",
    "right_shoulder",
    "right_elbow",
    "left_hip",
    "left_knee",
    "left_ankle",
    "left_shoulder",
    "left_elbow",
)
DOF_OF_TYPE = {"spherical": 4, "revolute": 1, "fixed": 0}


@dataclass(frozen=True)
class UrdfSkeleton:
    """Points of the humanoid in FK order: names, parent indices, offsets (P, 3) in metres, joint types, axes (P, 3)."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    types: tuple[str, ...]
    axes: np.ndarray


def _vector(element: ET.Element | None, attribute: str, default: str) -> np.ndarray:
    text = default if element is None else element.get(attribute, default)
    return np.array([float(v) for v in text.split()])


def read_urdf(path: Path, scale: float = URDF_SCALE) -> UrdfSkeleton:
    """The humanoid's joint tree below ROOT_LINK plus a ``head_centre`` point, offsets scaled to metres."""
    try:  # pybullet's humanoid.urdf ends with a NUL byte, which XML parsers reject
        robot = ET.fromstring(Path(path).read_bytes().rstrip(b"\0\r\n\t "))
    except (OSError, ET.ParseError) as err:
        raise InputError(f"{path}: not a readable URDF ({err})") from None
    joints = {j.find("child").get("link"): j for j in robot.iter("joint")}
    children: dict[str, list[str]] = {}
    for child, joint in joints.items():
        children.setdefault(joint.find("parent").get("link"), []).append(child)
    names, parents, offsets, types, axes = [ROOT_LINK], [-1], [np.zeros(3)], ["free"], [np.zeros(3)]
    stack = [(c, 0) for c in reversed(children.get(ROOT_LINK, []))]
    while stack:
        link, parent = stack.pop()
        joint = joints[link]
        names.append(joint.get("name"))
        parents.append(parent)
        offsets.append(_vector(joint.find("origin"), "xyz", "0 0 0") * scale)
        types.append(joint.get("type"))
        axes.append(_vector(joint.find("axis"), "xyz", "0 0 1"))
        stack.extend((c, len(names) - 1) for c in reversed(children.get(link, [])))
    head_link = robot.find(f"link[@name='{HEAD_LINK}']")
    if head_link is None or HEAD_LINK not in names:
        raise InputError(f"{path}: URDF has no '{HEAD_LINK}' link for the head")
    names.append("head_centre")
    parents.append(names.index(HEAD_LINK))
    offsets.append(_vector(head_link.find("collision/origin"), "xyz", "0 0 0") * scale)
    types.append("fixed")
    axes.append(np.zeros(3))
    missing = [n for n in CHANNEL_ORDER if n not in names]
    if missing:
        raise InputError(f"{path}: URDF lacks DeepMimic joints {missing}")
    return UrdfSkeleton(tuple(names), tuple(parents), np.array(offsets), tuple(types), np.array(axes))


def _quaternions(wxyz: np.ndarray) -> Rotation:
    return Rotation.from_quat(wxyz[:, [1, 2, 3, 0]])


def pose_points(frames: np.ndarray, skeleton: UrdfSkeleton) -> np.ndarray:
    """Skeleton points ``(T, P, 3)``, Y up, from DeepMimic frames ``(T, 44)`` (durations in column 0)."""
    num_frames = frames.shape[0]
    width = 8 + sum(DOF_OF_TYPE[skeleton.types[skeleton.names.index(n)]] for n in CHANNEL_ORDER)
    if frames.shape[1] != width:
        raise ValueError(f"frames have {frames.shape[1]} values, the URDF's joints need {width}")
    rotations = np.tile(np.eye(3), (num_frames, len(skeleton.names), 1, 1))
    offsets = np.broadcast_to(skeleton.offsets, (num_frames, *skeleton.offsets.shape)).copy()
    offsets[:, 0] = frames[:, 1:4]
    rotations[:, 0] = _quaternions(frames[:, 4:8]).as_matrix()
    column = 8
    for name in CHANNEL_ORDER:
        j = skeleton.names.index(name)
        dof = DOF_OF_TYPE[skeleton.types[j]]
        values = frames[:, column : column + dof]
        if dof == 4:
            rotations[:, j] = _quaternions(values).as_matrix()
        elif dof == 1:
            rotations[:, j] = Rotation.from_rotvec(values * skeleton.axes[j]).as_matrix()
        column += dof
    return forward_kinematics(skeleton.parents, offsets, rotations)


def resample_uniform(points: np.ndarray, durations: np.ndarray) -> tuple[np.ndarray, float]:
    """Points ``(T, ...)`` with frame durations ``(T,)`` onto a uniform grid at the median step; (points, fps)."""
    step = float(np.median(durations[:-1]))
    if not step > 0:
        raise ValueError(f"frame durations must be positive, median is {step}")
    times = np.concatenate([[0.0], np.cumsum(durations[:-1])])
    if np.allclose(np.diff(times), step, rtol=0.01):
        return points, rate_from_step(step)
    return interpolate(points, times, np.arange(0.0, times[-1] + 1e-9, step)), rate_from_step(step)


def is_deepmimic(path: Path) -> bool:
    """Whether a .txt/.json file starts like a DeepMimic clip (a JSON object with ``Frames``)."""
    with open(path, "rb") as f:
        head = f.read(4096)
    return head.lstrip().startswith(b"{") and b'"Frames"' in head


def load_deepmimic(
    path: Path, fps: float | None = None, urdf: Path | None = None, scale: float = URDF_SCALE
) -> list[Motion]:
    """One clip from a DeepMimic JSON file; the URDF is ``urdf`` or humanoid.urdf beside the clip."""
    urdf = Path(urdf) if urdf is not None else path.with_name(URDF_NAME)
    if not urdf.is_file():
        raise InputError(f"{path}: DeepMimic clip needs its {URDF_NAME} beside it (or pass urdf=...)")
    try:
        frames = np.asarray(json.loads(path.read_text(encoding="utf-8"))["Frames"], dtype=np.float64)
    except (ValueError, KeyError, TypeError, RecursionError) as err:
        raise InputError(f"{path}: not a DeepMimic clip ({type(err).__name__}: {err})") from None
    if frames.ndim != 2 or frames.shape[0] < 2:
        raise InputError(f"{path}: DeepMimic Frames must be a list of at least 2 equal-length rows")
    if not np.isfinite(frames).all():
        raise InputError(f"{path}: Frames contain NaN or infinite values")
    skeleton = read_urdf(urdf, scale)
    points, file_fps = resample_uniform(y_up_to_z_up(pose_points(frames, skeleton)), frames[:, 0])
    joints = apply_recipe(points, skeleton.names, DEEPMIMIC_RECIPE)
    return [Motion(joints=joints, fps=fps or file_fps, name=path.stem, extra={"format": "deepmimic"})]
