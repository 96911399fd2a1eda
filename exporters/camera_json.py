"""Cameras to and from the native calibration JSON (``platypose-calib`` version 1), as stored in the npz."""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from lifting.camera import Camera

FORMAT = "platypose-calib"
VERSION = 1


def camera_to_dict(camera: Camera) -> dict:
    """One camera as a JSON-ready dict with the native field names."""
    return {
        "name": camera.name,
        "size": list(camera.size),
        "K": camera.K.tolist(),
        "dist": camera.dist.tolist(),
        "R": camera.R.tolist(),
        "t": camera.t.tolist(),
        "time_offset_s": float(camera.time_offset_s),
    }


def cameras_to_json(cameras: Sequence[Camera]) -> str:
    """The native calibration JSON text for ``cameras``."""
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "units": "m",
        "world_up": "z",
        "cameras": [camera_to_dict(c) for c in cameras],
    }
    return json.dumps(doc)


def _rotation(entry: dict) -> np.ndarray:
    """Rotation matrix from ``R`` or a Rodrigues ``rvec``."""
    if "R" in entry:
        return np.asarray(entry["R"], dtype=np.float64).reshape(3, 3)
    rvec = np.asarray(entry["rvec"], dtype=np.float64).reshape(3)
    angle = float(np.linalg.norm(rvec))
    if angle < 1e-12:
        return np.eye(3)
    k = rvec / angle
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * skew + (1 - np.cos(angle)) * skew @ skew


def cameras_from_json(text: str) -> tuple[Camera, ...]:
    """Parse native calibration JSON text; raises ValueError naming the problem."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as err:
        raise ValueError(f"cameras are not valid JSON ({err.msg})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ValueError(f"cameras are not a {FORMAT} document")
    if doc.get("units", "m") != "m" or doc.get("world_up", "z") != "z":
        raise ValueError("cameras must be in metres with world up = z")
    cameras = []
    for i, entry in enumerate(doc.get("cameras", [])):
        try:
            cameras.append(
                Camera(
                    name=str(entry["name"]),
                    size=tuple(entry["size"]),
                    K=entry["K"],
                    dist=entry.get("dist", [0.0] * 5),
                    R=_rotation(entry),
                    t=entry.get("t", [0.0, 0.0, 0.0]),
                    time_offset_s=float(entry.get("time_offset_s", 0.0)),
                )
            )
        except (KeyError, TypeError, ValueError) as err:
            raise ValueError(f"camera {i} is malformed ({type(err).__name__}: {err})") from None
    return tuple(cameras)
