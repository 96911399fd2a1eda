"""BVH motion (any hierarchy, named onto ours by a naming convention or a user name map), by forward kinematics.

BVH is Y up by convention and rotated to our Z up with ``(x, y, z) -> (x, -z,
y)``; a file whose rest pose is taller along Z than along Y is taken as Z up
already. Units (cm, m, inches, mm, dm) are detected from the rest-pose height
(a standing human is 1.5-2 m) unless ``scale`` (metres per file unit) is given.
Rotation channels compose in their listed order (``Zrotation Xrotation
Yrotation`` is ``Rz Rx Ry``); position channels replace the joint's offset.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import (
    BVH_NAMING,
    LIMB_JOINTS,
    Recipe,
    apply_recipe,
    head_between,
    head_beyond,
    mocap_recipe,
)
from platypose.lifting.motion import Motion
from platypose.lifting.motion_io.kinematics import (
    LENGTH_UNITS,
    detect_length_unit,
    forward_kinematics,
    rate_from_step,
    y_up_to_z_up,
)

END_SUFFIX = "_end"  # an End Site is named after its joint plus this suffix


@dataclass(frozen=True)
class BvhClip:
    """A parsed BVH: node names (End Site: ``<joint>_end``), parents, offsets (N, 3), channels, values, frame time."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    values: np.ndarray
    frame_time: float


def parse_bvh(text: str) -> BvhClip:
    """Parse BVH text; raises ValueError on a malformed file."""
    tokens = text.split()
    if not tokens or tokens[0] != "HIERARCHY":
        raise ValueError("does not start with HIERARCHY")
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    stack: list[int] = []
    i = 1
    while tokens[i] != "MOTION":
        word = tokens[i]
        if word in ("ROOT", "JOINT"):
            names.append(tokens[i + 1])
            i += 2
        elif word == "End":
            names.append(names[stack[-1]] + END_SUFFIX)
            i += 2
        elif word == "{":
            parents.append(stack[-1] if stack else -1)
            stack.append(len(names) - 1)
            offsets.append([0.0, 0.0, 0.0])
            channels.append(())
            i += 1
        elif word == "}":
            stack.pop()
            i += 1
        elif word == "OFFSET":
            offsets[stack[-1]] = [float(v) for v in tokens[i + 1 : i + 4]]
            i += 4
        elif word == "CHANNELS":
            count = int(tokens[i + 1])
            channels[stack[-1]] = tuple(tokens[i + 2 : i + 2 + count])
            i += 2 + count
        else:
            raise ValueError(f"unexpected word {word!r} in HIERARCHY")
    if stack or not names:
        raise ValueError("unbalanced braces or empty hierarchy")
    if tokens[i + 1] != "Frames:" or tokens[i + 3 : i + 5] != ["Frame", "Time:"]:
        raise ValueError("MOTION must be followed by 'Frames: N' and 'Frame Time: dt'")
    num_frames, frame_time = int(tokens[i + 2]), float(tokens[i + 5])
    width = sum(len(c) for c in channels)
    data = tokens[i + 6 :]
    if num_frames < 1 or len(data) != num_frames * width:
        raise ValueError(f"expected {num_frames} frames of {width} values, found {len(data)} values")
    values = np.array(data, dtype=np.float64).reshape(num_frames, width)
    return BvhClip(tuple(names), tuple(parents), np.array(offsets), tuple(channels), values, frame_time)


def local_transforms(clip: BvhClip) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame local offsets ``(T, N, 3)`` and rotations ``(T, N, 3, 3)`` from the channel values."""
    num_frames = clip.values.shape[0]
    offsets = np.tile(clip.offsets, (num_frames, 1, 1))
    rotations = np.tile(np.eye(3), (num_frames, len(clip.names), 1, 1))
    column = 0
    for j, chans in enumerate(clip.channels):
        block = clip.values[:, column : column + len(chans)]
        rot_axes = "".join(c[0].upper() for c in chans if c.lower().endswith("rotation"))
        rot_cols = [k for k, c in enumerate(chans) if c.lower().endswith("rotation")]
        for k, c in enumerate(chans):
            if c.lower().endswith("position"):
                offsets[:, j, "XYZ".index(c[0].upper())] = block[:, k]
        if rot_axes:
            rotations[:, j] = Rotation.from_euler(rot_axes, block[:, rot_cols], degrees=True).as_matrix()
        column += len(chans)
    return offsets, rotations


def rest_up_and_height(clip: BvhClip) -> tuple[str, float]:
    """Up axis ('y' or 'z', the taller of the two in the rest pose) and the rest-pose height in file units."""
    rest = forward_kinematics(clip.parents, clip.offsets, np.tile(np.eye(3), (1, len(clip.names), 1, 1)))[0]
    extent_y, extent_z = np.ptp(rest[:, 1]), np.ptp(rest[:, 2])
    return ("z", float(extent_z)) if extent_z > extent_y else ("y", float(extent_y))


def _strip_namespace(name: str) -> str:
    return name.rsplit(":", 1)[-1]


def bvh_recipe(clip: BvhClip, name_map: Mapping[str, str] | None) -> Recipe:
    """Recipe for this file from ``name_map`` (limb joints, 'neck', optional 'head' -> BVH names) or a known naming."""
    names = {_strip_namespace(n): n for n in clip.names}
    if name_map is not None:
        missing_keys = [k for k in (*LIMB_JOINTS, "neck") if k not in name_map]
        if missing_keys:
            raise ValueError(f"name map lacks {missing_keys}")
        candidates = [({k: name_map[k] for k in LIMB_JOINTS}, name_map["neck"], name_map.get("head"))]
    else:
        candidates = list(BVH_NAMING.values())
    for limbs, skull, head_joint in candidates:
        head_names = list(head_joint) if isinstance(head_joint, Mapping) else [head_joint] if head_joint else []
        needed = [*limbs.values(), skull, *head_names]
        if not all(_strip_namespace(n) in names for n in needed):
            continue
        limbs = {k: names[_strip_namespace(v)] for k, v in limbs.items()}
        skull = names[_strip_namespace(skull)]
        if isinstance(head_joint, Mapping):
            head = {names[_strip_namespace(k)]: w for k, w in head_joint.items()}
        elif head_joint:
            head = {names[_strip_namespace(head_joint)]: 1.0}
        elif skull + END_SUFFIX in clip.names:
            head = head_between(skull, skull + END_SUFFIX)
        else:
            head = head_beyond(skull, clip.names[clip.parents[clip.names.index(skull)]])
        return mocap_recipe(limbs, {skull: 1.0}, head)
    if name_map is not None:
        absent = [n for n in needed if _strip_namespace(n) not in names]
        raise ValueError(f"name map names joints the file lacks: {absent}")
    raise ValueError(f"joint names fit no known naming ({', '.join(BVH_NAMING)}); pass a name map")


MAX_CHANNEL_VALUE = 1e6  # file units or degrees: beyond this a channel value is corrupt


def load_bvh(
    path: Path, fps: float | None = None, name_map: Mapping[str, str] | None = None, scale: float | None = None
) -> list[Motion]:
    """One clip from a BVH file; ``scale`` in metres per file unit (detected when None)."""
    try:
        clip = parse_bvh(path.read_text(encoding="utf-8", errors="replace"))
    except (ValueError, IndexError) as err:
        raise InputError(f"{path}: not a valid BVH file ({err})") from None
    with np.errstate(invalid="ignore"):
        bad = ~(np.abs(clip.values) <= MAX_CHANNEL_VALUE)  # also NaN and infinite values
    if bad.any():
        frame, channel = (int(v[0]) for v in np.nonzero(bad))
        raise InputError(
            f"{path}: frame {frame} channel {channel} is {clip.values[frame, channel]:.6g} "
            f"(not a number, or beyond +-{MAX_CHANNEL_VALUE:g}: a corrupt value)"
        )
    if not clip.frame_time > 0 and fps is None:
        raise InputError(f"{path}: Frame Time must be positive, got {clip.frame_time}")
    try:
        recipe = bvh_recipe(clip, name_map)
    except ValueError as err:
        raise InputError(f"{path}: {err}") from None
    up, height = rest_up_and_height(clip)
    unit = None
    if scale is None:
        unit = detect_length_unit(height)
        scale = LENGTH_UNITS[unit]
    points = forward_kinematics(clip.parents, *local_transforms(clip)) * scale
    joints = apply_recipe(y_up_to_z_up(points) if up == "y" else points, clip.names, recipe)
    finite = np.isfinite(joints).all(axis=(1, 2))
    if not finite.all():
        raise InputError(f"{path}: frame {int(np.argmin(finite))} gives NaN or infinite joint positions")
    extra = {"format": "bvh", "metres_per_unit": scale, "unit": unit or "given", "up": up}
    return [Motion(joints=joints, fps=fps or rate_from_step(clip.frame_time), name=path.stem, extra=extra)]
