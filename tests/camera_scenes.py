"""Synthetic takes for the camera estimate: bundled mocap walkers on a floor, seen by a camera of known pose."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.lifting.calibration.pose_above_floor import posed_camera
from platypose.lifting.camera import project

MOTION = Path(__file__).resolve().parents[1] / "data" / "motion" / "cmu-amc"
WALKS = ("02_02.npz", "02_03.npz")  # CMU subject 2 walking and running


def walkers(places: list[tuple[float, float, float]], frames: int = 60) -> np.ndarray:
    """People (P, T, 17, 3) walking bundled CMU clips, each turned to ``heading`` (degrees) and moved so that its
    first pelvis is at (x, y) on the floor z = 0 (the clip's lowest ankle on it): ``places`` of (x, y, heading)."""
    people = []
    for p, (x, y, heading) in enumerate(places):
        joints = np.load(MOTION / WALKS[p % len(WALKS)])["joints"].astype(np.float64)
        joints = np.concatenate([joints] * (frames // len(joints) + 1))[:frames]
        joints[..., 2] -= np.min(joints[:, (3, 6), 2]) - 0.07  # ankles 7 cm above the floor at their lowest
        turn = np.radians(heading)
        c, s = np.cos(turn), np.sin(turn)
        start = joints[0, 0, :2].copy()
        flat = (joints[..., :2] - start) @ np.array([[c, s], [-s, c]])
        joints[..., :2] = flat + np.array([x, y])
        people.append(joints)
    return np.stack(people)


def scene_keypoints(
    people: np.ndarray, pitch: float, roll: float, focal: float, height: float, size=(1080, 1920), noise_px=1.5, seed=0
):
    """Keypoints (T, P, 17, 3) of ``people`` (P, T, 17, 3) seen by the posed camera, with pixel noise, and it."""
    camera = posed_camera("synthetic", size, focal, pitch, roll, height)
    pixels = project(people.reshape(-1, 3), camera).reshape(*people.shape[:-1], 2)
    pixels = pixels + np.random.default_rng(seed).normal(0.0, noise_px, pixels.shape)
    keypoints = np.concatenate([pixels, np.ones((*pixels.shape[:-1], 1))], axis=-1)
    return np.moveaxis(keypoints, 0, 1), camera
