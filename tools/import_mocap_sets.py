"""Rebuild the converted mocap folders in data/motion from the public repositories they came from.

Each set is read with platypose's own importers (BVH namings ``character_creator``, ``poser`` and
``rigify``; the CMU exponential-map reader), rescaled where its rig is not human-sized, resampled to
30 fps and written as plain npz clips (``joints`` (T, 17, 3) float32 metres Z up, ``fps``,
``joint_names``), with ``SOURCE.json`` (source and licence, read per clip by the loader), the
repository's licence text where it has one, and ``clips.json`` (each clip's source file, frames, rate).

Clips that repeat motion already in data/motion, or in an earlier set, are left out: the same CMU
trial reaches us through several conversions (``duplicates`` below). A set may cap its minutes
(idle standing must not dominate the training mix).

Usage (each DIR a checkout of the repository named in SETS)::

    python tools/import_mocap_sets.py --out data/motion \
        cmu-expmap=DIR cmu-amc=DIR cmu-iclone=DIR cmu-poser-salsa=DIR reactidle=DIR
"""

from __future__ import annotations

import argparse
import json
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from platypose.lifting.motion import Motion
from platypose.lifting.motion_io import load_motion, load_motion_paths
from platypose.lifting.skeleton import BONES, JOINT_NAMES
from platypose.lifting.timebase import resample

FPS = 30.0
CMU_TERMS = (
    "CMU Graphics Lab Motion Capture Database terms: free for all uses, may be included in commercially sold "
    "products, the data itself may not be resold"
)


@dataclass(frozen=True)
class MocapSet:
    """One converted folder: where its files are in the repository, how to scale them, and its provenance."""

    repository: str
    pattern: str
    source: str
    licence: str
    licence_file: str | None = None
    scale: float = 1.0
    max_minutes: float | None = None


SETS: dict[str, MocapSet] = {
    "cmu-expmap": MocapSet(
        "chaneyddtt/Convolutional-Sequence-to-Sequence-Model-for-Human-Dynamics (commit f27ccb4)",
        "data/cmu_mocap/*/*/*.txt",
        "CMU mocap (basketball, basketball signals, directing traffic, jumping, running, soccer, walking, washing "
        "windows) as exponential maps on the standard CMU skeleton, 120 Hz",
        f"MIT (repository, LICENSE-chaneyddtt.txt); {CMU_TERMS}",
        "LICENSE",
    ),
    "cmu-amc": MocapSet(
        "cyun9601/CMU-MOCAP-Data (commit 2bedcd3)",
        "data/CMU/asfamc/subjects/*/*.amc",
        "CMU mocap subjects 1 (playground: climbing, hanging, jumping), 2 (walks, runs, jumps, swordplay) and 3 "
        "(walking on uneven terrain) as the "
        "original ASF/AMC files, 120 Hz",
        f"{CMU_TERMS}; the repository states no licence of its own",
    ),
    "cmu-iclone": MocapSet(
        "DragonForgedTheArtist/IClone-CMU-Mocap (commit 79529f9)",
        "All_BVH/subjects/*/*.bvh",
        "CMU mocap subjects 1-7 converted from the AMC files to BVH on a Character Creator rig, 60 Hz",
        f"{CMU_TERMS}; the repository states no licence of its own for the mechanical conversion",
    ),
    # The repository's clips are scaled to 0.7 of the performers (ankle to head 1.13-1.15 m): 1.44 brings
    # them back to 1.63-1.66 m, the CMU rig of cmu-iclone.
    "cmu-poser-salsa": MocapSet(
        "beemsoft/webxr-handtracking-playground (commit c75be06)",
        "public/shared/bvh/6[01]/*.bvh",
        "CMU mocap subjects 60 and 61 (salsa, lead and follow) as Poser-rig BVH, 120 Hz, rescaled by 1.44",
        f"{CMU_TERMS}; the repository states no licence of its own for the conversion",
        scale=1.44,
    ),
    "reactidle": MocapSet(
        "Enekoassets/ReActIdle (commit 90b0ac7)",
        "*/*.bvh",
        "ReActIdle: acted and genuine idle standing (Rigify-style BVH, 24 Hz); capped so idling stays a small share",
        "MIT (LICENSE-reactidle.txt)",
        "LICENSE.txt",
        max_minutes=4.0,
    ),
}
LICENCE_COPY = {"cmu-expmap": "LICENSE-chaneyddtt.txt", "reactidle": "LICENSE-reactidle.txt"}


def bone_directions(joints: np.ndarray) -> np.ndarray:
    """Unit bone vectors ``(T, B, 3)`` turned so that the hips point along x (heading removed)."""
    hips = joints[:, JOINT_NAMES.index("left_hip")] - joints[:, JOINT_NAMES.index("right_hip")]
    heading = np.arctan2(hips[:, 1], hips[:, 0])
    cos, sin = np.cos(-heading), np.sin(-heading)
    turn = np.zeros((len(joints), 3, 3))
    turn[:, 0, 0], turn[:, 0, 1], turn[:, 1, 0], turn[:, 1, 1], turn[:, 2, 2] = cos, -sin, sin, cos, 1
    bones = np.stack([joints[:, child] - joints[:, parent] for child, parent in BONES], axis=1)
    bones /= np.linalg.norm(bones, axis=-1, keepdims=True) + 1e-9
    return np.einsum("tij,tbj->tbi", turn, bones)


def motion_distance_deg(a: np.ndarray, b: np.ndarray, max_shift: int = 15) -> float:
    """Mean bone-direction angle (degrees) between two 30 fps clips at their best time shift, over the overlap."""
    da, db = bone_directions(a), bone_directions(b)
    best = np.inf
    for shift in range(-max_shift, max_shift + 1):
        x, y = (da[shift:], db) if shift >= 0 else (da, db[-shift:])
        n = min(len(x), len(y))
        if n < 15:
            continue
        cos = np.clip(np.sum(x[:n] * y[:n], axis=-1), -1, 1)
        best = min(best, float(np.degrees(np.arccos(cos)).mean()))
    return best


Reference = tuple[str, float, np.ndarray]  # name, duration at the source's own rate (s), joints at 30 fps


def duplicates(clip: np.ndarray, duration_s: float, references: list[Reference], limit_deg: float = 8.0) -> str | None:
    """Name of a reference clip whose motion ``clip`` repeats, else None.

    A repeat is the same trial converted another way: the same duration (within 1.5 frames at 30 fps:
    conversions at 120 and 60 Hz, a rest-pose first row or not) and bone directions within ``limit_deg`` on average (the same trial
    on two rigs: 5-6 degrees; two different trials of one walking or running subject can come as close,
    so the duration must agree too).
    """
    for name, ref_duration, ref in references:
        if abs(ref_duration - duration_s) <= 1.5 / FPS and motion_distance_deg(clip, ref) < limit_deg:
            return name
    return None


def settled_segments(
    joints: np.ndarray, fps: float, factor: float = 8.0, floor_m_s: float = 8.0, shortest_s: float = 1.0
) -> list[slice]:
    """The runs of frames between jumps, each at least ``shortest_s`` long. Several of these sources start with
    a rest pose (the exponential-map files' first row) or a blend out of one (the Poser clips' first frames),
    and some flip a limb for a frame or two mid-clip (a walker's joint moving 20-40 m/s relative to the
    pelvis). A step is a jump when some joint moves, relative to the pelvis, ``factor`` times the clip's
    median step and faster than ``floor_m_s``; the clip is cut there."""
    relative = joints - joints[:, :1]
    step = np.linalg.norm(np.diff(relative, axis=0), axis=-1).max(axis=-1)
    jump = (step > factor * np.median(step)) & (step * fps > floor_m_s)
    cuts = [0, *(np.flatnonzero(jump) + 1).tolist(), len(joints)]
    return [slice(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b - a >= shortest_s * fps]


def at_30fps(motion: Motion, scale: float) -> list[np.ndarray]:
    """A clip's runs between jumps (:func:`settled_segments`), each resampled to 30 fps and scaled, float64."""
    return [
        resample(motion.joints[run] * scale, motion.fps, FPS) for run in settled_segments(motion.joints, motion.fps)
    ]


def clip_name(path: Path) -> str:
    """A clip's name: the file's stem, prefixed by its split where the repository has one (train/, test/)."""
    split = next((part for part in path.parts if part in ("train", "test")), None)
    return f"{split}_{path.stem}" if split else path.stem


def convert_set(name: str, spec: MocapSet, checkout: Path, out: Path, references: list[Reference]) -> dict:
    """Convert one set into ``out/name``; returns its clip table. Adds the kept clips to ``references``."""
    folder = out / name
    folder.mkdir(parents=True, exist_ok=True)
    table: dict[str, dict] = {}
    minutes = 0.0
    for path in sorted(checkout.glob(spec.pattern)):
        if path.suffix == ".txt" and "cmu_mocap" not in str(path):
            continue
        for motion in load_motion(path):
            whole = resample(motion.joints * spec.scale, motion.fps, FPS)
            entry = {"file": str(path.relative_to(checkout)), "frames": motion.num_frames, "fps": motion.fps}
            repeat = duplicates(whole, motion.num_frames / motion.fps, references)
            if repeat is not None:
                table[clip_name(path)] = {**entry, "left_out": f"repeats {repeat}"}
                continue
            references.append((f"{name}/{clip_name(path)}", motion.num_frames / motion.fps, whole))
            runs = at_30fps(motion, spec.scale)
            for index, joints in enumerate(runs):
                clip = clip_name(path) + (f"_part{index + 1}" if len(runs) > 1 else "")
                if spec.max_minutes is not None and minutes + len(joints) / FPS / 60 > spec.max_minutes:
                    table[clip] = {**entry, "left_out": f"over the set's cap of {spec.max_minutes} minutes"}
                    continue
                minutes += len(joints) / FPS / 60
                np.savez_compressed(
                    folder / f"{clip}.npz",
                    joints=joints.astype(np.float32),
                    fps=np.float64(FPS),
                    joint_names=np.array(JOINT_NAMES),
                )
                table[clip] = entry
    source = {"source": f"{spec.repository}: {spec.source}", "licence": spec.licence}
    (folder / "SOURCE.json").write_text(json.dumps(source, indent=1) + "\n", encoding="utf-8")
    (folder / "clips.json").write_text(json.dumps(table, indent=1) + "\n", encoding="utf-8")
    if spec.licence_file:
        shutil.copyfile(checkout / spec.licence_file, folder / LICENCE_COPY[name])
    return table


def main() -> None:
    """Convert the sets named on the command line, in the order given, skipping repeats of data/motion."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkouts", nargs="+", help="NAME=DIR for each set (names: " + ", ".join(SETS) + ")")
    parser.add_argument("--out", type=Path, default=Path("data/motion"))
    args = parser.parse_args()
    wanted = [item.split("=", 1) for item in args.checkouts]
    converted = {name for name, _ in wanted}
    existing = [
        (f"{folder.name}/{m.name}", m.num_frames / m.fps, resample(m.joints, m.fps, FPS))
        for folder in sorted(args.out.iterdir())
        if folder.is_dir() and folder.name not in converted
        for m in load_motion_paths([folder])
        if np.isfinite(m.joints).all()
    ]
    for name, checkout in wanted:
        table = convert_set(name, SETS[name], Path(checkout), args.out, existing)
        kept = [k for k, v in table.items() if "left_out" not in v]
        print(f"{name}: {len(kept)} clips kept, {len(table) - len(kept)} left out")
        for clip, entry in table.items():
            if "left_out" in entry:
                print(f"  {clip}: {entry['left_out']}")


if __name__ == "__main__":
    main()
