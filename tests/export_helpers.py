"""Shared test material for the exporter tests: LiftResults built from real climbing mocap."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.exporters.result import LiftResult
from platypose.lifting.camera import Camera, project
from platypose.lifting.motion_io import load_motion

CLIMB = "motion/holosoma-climb/mocap_climb_seq_0_joint_positions_f900-3700.npy"


def climb_joints(data_dir: Path, frames: int, step: int = 1) -> tuple[np.ndarray, float]:
    """The first ``frames`` frames (every ``step``-th) of a real climbing clip, (T, 17, 3) metres, and its fps."""
    motion = load_motion(data_dir / CLIMB)[0]
    return motion.joints[: frames * step : step], motion.fps / step


def look_at_camera(name: str, target: np.ndarray, eye: np.ndarray, size: tuple[int, int], focal: float) -> Camera:
    """A distortion-free camera at ``eye`` looking at ``target`` with world Z up."""
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    R = np.stack([right, down, forward])
    K = [[focal, 0, size[1] / 2], [0, focal, size[0] / 2], [0, 0, 1]]
    return Camera(name=name, size=size, K=K, dist=[0.01, -0.002, 0.0, 0.0, 0.0], R=R, t=-R @ eye)


def camera_facing(joints: np.ndarray) -> Camera:
    """A camera 4 m in front of (world -y) the mean pelvis of ``joints`` (T, 17, 3)."""
    centre = joints[:, 0].mean(0)
    return look_at_camera("cam01", centre, centre + [0.0, -4.0, 0.5], (1920, 1080), 1600.0)


def make_result(
    joints: np.ndarray, fps: float, num_hypotheses: int, cameras: tuple[Camera, ...], seed: int = 0
) -> LiftResult:
    """Hypotheses as smooth random perturbations of real ``joints`` (T, 17, 3); 2D keypoints projected from them."""
    rng = np.random.default_rng(seed)
    T = len(joints)
    t = np.arange(T) / fps
    freq = rng.uniform(0.2, 2.0, size=(num_hypotheses, 1, 17, 3))
    phase = rng.uniform(0, 2 * np.pi, size=(num_hypotheses, 1, 17, 3))
    amp = rng.uniform(0.005, 0.03, size=(num_hypotheses, 1, 17, 3))
    wobble = amp * np.sin(2 * np.pi * freq * t[None, :, None, None] + phase)
    hypotheses = (joints[None] + wobble)[None].astype(np.float32)
    median = np.median(hypotheses, axis=1)
    keypoints = np.zeros((len(cameras), 1, T, 17, 3), dtype=np.float32)
    energy = np.zeros((1, num_hypotheses, T), dtype=np.float32)
    for c, camera in enumerate(cameras):
        keypoints[c, 0, ..., :2] = project(joints, camera) + rng.normal(0, 2.0, size=(T, 17, 2))
        keypoints[c, 0, ..., 2] = rng.uniform(0.3, 1.0, size=(T, 17))
        residual = project(hypotheses[0], camera) - keypoints[c, 0, None, ..., :2]
        energy[0] += (keypoints[c, 0, None, ..., 2] * (residual**2).sum(-1)).mean(-1) / camera.width**2
    return LiftResult(
        hypotheses=hypotheses,
        median=median,
        keypoints2d=keypoints,
        frame_times=t,
        fps=fps,
        track_ids=np.array([3]),
        cameras=cameras,
        energy=energy,
        meta={
            "version": "test",
            "arguments": ["lift", "clip.mp4"],
            "prior_sha256": "0" * 64,
            "timings": {"total_s": 1.5},
        },
    )


def two_person_result(data_dir: Path) -> LiftResult:
    """Two persons from two real clips, the second absent for its first 5 frames, with two cameras."""
    a, fps = climb_joints(data_dir, 30)
    b = load_motion(data_dir / "motion/holosoma-climb/mocap_climb_seq_1_joint_positions_f0-2422.npy")[0].joints[:30]
    centre = a[:, 0].mean(0)
    cams = (camera_facing(a), look_at_camera("cam02", centre, centre + [3.0, -3.0, 0.8], (1920, 1080), 1500.0))
    ra, rb = make_result(a, fps, 6, cams, seed=1), make_result(b, fps, 6, cams, seed=2)
    hyp = np.concatenate([ra.hypotheses, rb.hypotheses])
    med = np.concatenate([ra.median, rb.median])
    kp = np.concatenate([ra.keypoints2d, rb.keypoints2d], axis=1)
    hyp[1, :, :5] = np.nan
    med[1, :5] = np.nan
    kp[:, 1, :5] = 0.0
    return LiftResult(
        hypotheses=hyp,
        median=med,
        keypoints2d=kp,
        frame_times=ra.frame_times,
        fps=fps,
        track_ids=np.array([0, 7]),
        cameras=cams,
        energy=np.concatenate([ra.energy, rb.energy]),
        meta=ra.meta,
    )


def read_entities(path: Path, store: str = "recording") -> dict[str, dict[str, list]]:
    """A rerun recording read back: per entity path: column name -> values, static rows under 'static:<column>', time-sorted otherwise."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    reader = RrdReader(path)
    entry = (reader.recordings() if store == "recording" else reader.blueprints())[0]
    out: dict[str, dict[str, list]] = {}
    for chunk in reader.stream(store=entry).to_chunks():
        batch = chunk.to_record_batch()
        cols = out.setdefault(chunk.entity_path, {})
        for name in batch.schema.names:
            if name.startswith("rerun.controls"):
                continue
            column = batch.column(name)
            if pa.types.is_timestamp(column.type) or pa.types.is_duration(column.type):
                column = column.cast(pa.int64())
            key = f"static:{name}" if chunk.is_static else name
            if name.endswith(":blob"):  # one blob per row, as bytes
                values = [row.values.flatten().to_numpy(zero_copy_only=False).tobytes() for row in column]
            else:
                values = column.to_pylist()
            cols.setdefault(key, []).extend(values)
    return out


def largest_bone_turn(joints: np.ndarray) -> float:
    """Largest angle (degrees) any bone of joints (T, 17, 3) turns between consecutive frames."""
    from platypose.lifting.skeleton import BONES

    bones = np.stack([joints[:, c] - joints[:, p] for c, p in BONES], axis=1)
    bones /= np.linalg.norm(bones, axis=-1, keepdims=True)
    return float(np.degrees(np.arccos(np.clip(np.sum(bones[1:] * bones[:-1], -1), -1, 1))).max())
