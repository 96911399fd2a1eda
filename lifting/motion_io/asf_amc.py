"""Acclaim ASF skeleton + AMC motion (CMU mocap), by forward kinematics; Y up, 120 fps unless told.

ASF lengths are in units of ``1 / length`` inches (``:units length 0.45``: L in
the file is L / 0.45 inches). Each bone rotates about its start: its frame
relative to its parent is ``C M C^-1``, ``C`` from the bone's ``axis`` and ``M``
from the AMC values in the order of its ``dof`` (both fixed-axis Euler angles).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import CMU_ASF_RECIPE, apply_recipe
from platypose.lifting.motion import Motion
from platypose.lifting.motion_io.kinematics import forward_kinematics, y_up_to_z_up

DEFAULT_FPS = 120.0
INCH_M = 0.0254


@dataclass
class Bone:
    """One ASF bone: unit direction and length (file units) in the rest frame, axis Euler angles and order, dofs."""

    name: str
    direction: np.ndarray
    length: float
    axis: np.ndarray
    axis_order: str
    dof: list[str] = field(default_factory=list)


@dataclass
class AsfSkeleton:
    """Bones by name, children lists (``root`` first), root dof order and axis, metres per length unit, angle unit."""

    bones: dict[str, Bone]
    children: dict[str, list[str]]
    root_order: list[str]
    root_axis: np.ndarray
    root_axis_order: str
    metres_per_unit: float
    degrees: bool


def _sections(text: str) -> dict[str, list[list[str]]]:
    """ASF keyword sections (``:name`` -> token lines), comments dropped."""
    sections: dict[str, list[list[str]]] = {}
    current = None
    for line in text.splitlines():
        tokens = line.split("#", 1)[0].split()
        if not tokens:
            continue
        if tokens[0].startswith(":"):
            current = tokens[0][1:].lower()
            sections[current] = [tokens[1:]] if len(tokens) > 1 else []
        elif current is not None:
            sections[current].append(tokens)
    return sections


def read_asf(path: Path) -> AsfSkeleton:
    """Parse an ASF skeleton file."""
    sections = _sections(path.read_text(encoding="utf-8", errors="replace"))
    for needed in ("root", "bonedata", "hierarchy"):
        if needed not in sections:
            raise InputError(f"{path}: not an ASF skeleton (no :{needed} section)")
    units = {t[0].lower(): t[1] for t in sections.get("units", []) if len(t) >= 2}
    root = {t[0].lower(): t[1:] for t in sections["root"] if t}
    bones: dict[str, Bone] = {}
    block: dict[str, list[str]] = {}
    for tokens in sections["bonedata"]:
        key = tokens[0].lower()
        if key == "begin":
            block = {}
        elif key == "end":
            bones[block["name"][0]] = Bone(
                name=block["name"][0],
                direction=np.array([float(v) for v in block["direction"]]),
                length=float(block["length"][0]),
                axis=np.array([float(v) for v in block["axis"][:3]]),
                axis_order=block["axis"][3].lower(),
                dof=[d.lower() for d in block.get("dof", [])],
            )
        elif key != "limits" and not key.startswith("("):
            block[key] = tokens[1:]
    children: dict[str, list[str]] = {}
    for tokens in sections["hierarchy"]:
        if tokens[0].lower() not in ("begin", "end"):
            children.setdefault(tokens[0], []).extend(tokens[1:])
    unknown = [b for kids in children.values() for b in kids if b not in bones]
    if unknown:
        raise InputError(f"{path}: hierarchy names bones without bonedata: {unknown}")
    _check_tree(path, children)
    return AsfSkeleton(
        bones=bones,
        children=children,
        root_order=[t.lower() for t in root.get("order", ["tx", "ty", "tz", "rx", "ry", "rz"])],
        root_axis=np.array([float(v) for v in root.get("orientation", ["0", "0", "0"])]),
        root_axis_order=root.get("axis", ["XYZ"])[0].lower(),
        metres_per_unit=INCH_M / float(units.get("length", 1.0)),
        degrees=units.get("angle", "deg").lower().startswith("deg"),
    )


def _check_tree(path: Path, children: dict[str, list[str]]) -> None:
    """InputError unless the hierarchy ``children`` is a tree under ``root``: no bone its own child, none listed
    twice (under one parent or two: a cycle needs a bone with two parents once it hangs from the root), the root
    nobody's child. One pass over the links, so walking from the root then visits each bone once."""
    parent_of: dict[str, str] = {}
    for parent, kids in children.items():
        for kid in kids:
            if kid == parent:
                raise InputError(f"{path}: hierarchy lists bone {kid!r} as its own child")
            if kid == "root":
                raise InputError(f"{path}: hierarchy lists the root as a child of {parent!r}")
            if kid in parent_of:
                raise InputError(
                    f"{path}: hierarchy lists bone {kid!r} twice (under {parent_of[kid]!r} and {parent!r}): not a tree"
                )
            parent_of[kid] = parent


def read_amc(path: Path) -> dict[str, np.ndarray]:
    """AMC values per bone name, each ``(T, n_values)``, frames in file order."""
    values: dict[str, list[list[float]]] = {}
    num_frames = 0
    for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
        tokens = line.split()
        if not tokens or tokens[0].startswith(("#", ":")):
            continue
        if len(tokens) == 1 and tokens[0].isdigit():
            num_frames += 1
            continue
        if num_frames == 0:
            raise ValueError(f"bone values before the first frame number: {line.strip()[:40]!r}")
        rows = values.setdefault(tokens[0], [])
        if len(rows) != num_frames - 1:
            raise ValueError(f"frame {num_frames}: bone {tokens[0]!r} missing in an earlier frame or repeated")
        rows.append([float(v) for v in tokens[1:]])
    if num_frames == 0:
        raise ValueError("no frames")
    incomplete = [name for name, rows in values.items() if len(rows) != num_frames]
    if incomplete:
        raise ValueError(f"bones {incomplete} missing in some of the {num_frames} frames")
    return {name: np.array(rows) for name, rows in values.items()}


def _rotation(seq: str, angles: np.ndarray, degrees: bool) -> np.ndarray:
    """Fixed-axis Euler rotations ``(T, 3, 3)`` (``seq`` like 'xyz'; an empty seq is identity)."""
    if not seq:
        return np.tile(np.eye(3), (angles.shape[0], 1, 1))
    return Rotation.from_euler(seq, angles, degrees=degrees).as_matrix()


def pose_points(skeleton: AsfSkeleton, motion: dict[str, np.ndarray]) -> tuple[list[str], np.ndarray]:
    """Names and positions ``(T, P, 3)`` in metres (file axes) of the root and every bone's end."""
    num_frames = len(motion["root"])
    names, parents, offsets, rotations = ["root"], [-1], [], []
    root_values = motion["root"]
    translation = [root_values[:, skeleton.root_order.index(a)] for a in ("tx", "ty", "tz")]
    offsets.append(np.stack(translation, axis=1))
    root_dofs = [a for a in skeleton.root_order if a.startswith("r")]
    root_angles = root_values[:, [skeleton.root_order.index(a) for a in root_dofs]]
    root_m = _rotation("".join(a[1] for a in root_dofs), root_angles, skeleton.degrees)
    root_c = Rotation.from_euler(skeleton.root_axis_order, skeleton.root_axis, degrees=skeleton.degrees).as_matrix()
    rotations.append(root_c @ root_m @ root_c.T)
    stack = [(b, 0) for b in reversed(skeleton.children.get("root", []))]
    while stack:
        name, parent = stack.pop()
        bone = skeleton.bones[name]
        c = Rotation.from_euler(bone.axis_order, bone.axis, degrees=skeleton.degrees).as_matrix()
        values = motion.get(name, np.zeros((num_frames, len(bone.dof))))
        if values.shape[1] != len(bone.dof):
            raise ValueError(f"bone {name!r} has {values.shape[1]} values, its dof {bone.dof} needs {len(bone.dof)}")
        m = _rotation("".join(d[1] for d in bone.dof), values, skeleton.degrees)
        names += [f"{name}@start", name]
        parents += [parent, len(names) - 2]
        offsets += [np.zeros((num_frames, 3)), np.broadcast_to(bone.length * bone.direction, (num_frames, 3))]
        rotations += [c @ m @ c.T, np.tile(np.eye(3), (num_frames, 1, 1))]
        stack.extend((child, len(names) - 1) for child in reversed(skeleton.children.get(name, [])))
    points = forward_kinematics(parents, np.stack(offsets, axis=1), np.stack(rotations, axis=1))
    return names, points * skeleton.metres_per_unit


def find_asf(amc: Path) -> Path:
    """The .asf of an AMC file: same stem, the subject before '_' (CMU ``01_02.amc`` -> ``01.asf``), or the only one."""
    for candidate in (amc.with_suffix(".asf"), amc.with_name(amc.stem.split("_")[0] + ".asf")):
        if candidate.is_file():
            return candidate
    found = sorted(amc.parent.glob("*.asf"))
    if len(found) == 1:
        return found[0]
    raise InputError(f"{amc}: cannot tell which .asf skeleton belongs to it ({len(found)} in the folder); pass asf=...")


def load_amc(path: Path, fps: float | None = None, asf: Path | None = None) -> list[Motion]:
    """One clip from an AMC file and its ASF skeleton (found beside it unless given)."""
    asf = Path(asf) if asf is not None else find_asf(path)
    try:
        skeleton = read_asf(asf)
    except InputError:
        raise  # already one line naming the file
    except (ValueError, KeyError, IndexError) as err:
        raise InputError(f"{asf}: broken ASF skeleton ({type(err).__name__}: {err})") from None
    motion = read_amc(path)
    if "root" not in motion:
        raise InputError(f"{path}: AMC has no root values")
    names, points = pose_points(skeleton, motion)
    joints = apply_recipe(y_up_to_z_up(points), names, CMU_ASF_RECIPE)
    if not np.isfinite(joints).all():
        raise InputError(f"{path}: motion gives NaN or infinite joint positions")
    extra = {"format": "asf_amc", "skeleton": asf.name}
    return [Motion(joints=joints, fps=fps or DEFAULT_FPS, name=path.stem, extra=extra)]
