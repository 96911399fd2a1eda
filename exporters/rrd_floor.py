"""The floor, the estimated camera, each person's plausibility and who they are in a rerun recording (logged by
:func:`exporters.rrd.write_rrd`).

Entity paths (static, under the Z-up ``world``):

- ``world/cameras/<cam>/estimate``: where the lift estimated its one camera (no calibration), a text document with
  each quantity's value, spread and source, and each source dropped
  (:func:`platypose.exporters.horizon.camera_caption`); ``world/cameras/<cam>/horizon``: its horizon in the camera's
  image (:func:`log_estimated_camera`);

- ``world/floor``: the floor plane as a grid of lines (``GRID_EXTENT`` metres either way of the point of
  the floor nearest the people's mean pelvis, a line every ``GRID_STEP``), labelled with where it came from;
- ``world/people/p<id>/plausibility``: a text document with the person's plausibility figures and flags
  (:mod:`lifting.checks.plausibility`);
- ``who/p<id>`` and ``who/p<id>/thumbnail``: where the person is best seen (camera, frame, image box) and that
  box cut from the video (:func:`log_who`).
"""

from __future__ import annotations

import json

import numpy as np
import rerun as rr

from platypose.exporters.horizon import HORIZON_PX, HORIZON_RGB, camera_caption, horizon_curve

GRID_EXTENT = 5.0  # metres
GRID_STEP = 0.5  # metres
FLOOR_RGBA = (150, 150, 150, 255)


def floor_grid(normal: np.ndarray, offset: float, center: np.ndarray) -> np.ndarray:
    """Line segments ``(L, 2, 3)`` of a square grid on the plane ``normal . x + offset = 0`` about ``center``'s foot."""
    normal = np.asarray(normal, dtype=np.float64)
    foot = center - (center @ normal + offset) * normal
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    ticks = np.arange(-GRID_EXTENT, GRID_EXTENT + 1e-9, GRID_STEP)
    lines = [[foot + a * u - GRID_EXTENT * v, foot + a * u + GRID_EXTENT * v] for a in ticks]
    lines += [[foot + a * v - GRID_EXTENT * u, foot + a * v + GRID_EXTENT * u] for a in ticks]
    return np.asarray(lines)


def log_floor_and_plausibility(
    rec: rr.RecordingStream, floor: dict | None, plausibility: list[dict], track_ids, center: np.ndarray
) -> None:
    """Log the floor (``{"normal", "offset_m", "source"}`` as in ``meta["floor"]``, or None: nothing) and each
    person's plausibility report (``meta["plausibility"]``, one per track id) into ``rec``, statically."""
    if floor is not None:
        segments = floor_grid(np.asarray(floor["normal"]), float(floor["offset_m"]), np.asarray(center, float))
        rec.log(
            "world/floor",
            rr.LineStrips3D(segments, colors=[FLOOR_RGBA], radii=[0.004], labels=[f"floor ({floor['source']})"]),
            static=True,
        )
    for track, report in zip(track_ids, plausibility):
        flags = (report.get("flag_text") or ", ".join(report.get("flags", []))) if report.get("flags") else "none"
        text = f"flagged: {flags}\n\n```json\n{json.dumps(report, indent=2)}\n```"
        rec.log(f"world/people/p{track}/plausibility", rr.TextDocument(text, media_type="text/markdown"), static=True)


def log_estimated_camera(rec: rr.RecordingStream, result) -> None:
    """Log the estimated camera's record (``meta["camera"]``) as text and its horizon as a line (a curve through a
    bending lens) in its image into ``rec``, statically; nothing where the lift had a calibration."""
    caption = camera_caption(result.meta or {})
    if not caption:
        return
    camera = result.cameras[0]
    entity = f"world/cameras/{camera.name}"
    text = "\n".join(f"- {line.strip()}" for line in caption)
    rec.log(
        f"{entity}/estimate",
        rr.TextDocument(f"**camera estimated without a calibration**\n\n{text}", media_type="text/markdown"),
        static=True,
    )
    curve = horizon_curve(camera)
    if curve is not None:
        strip = rr.LineStrips2D([curve], colors=[HORIZON_RGB], radii=[HORIZON_PX / 2], labels=["horizon"])
        rec.log(f"{entity}/horizon", strip, static=True)


def log_who(rec: rr.RecordingStream, result, frames: dict, pictures: dict) -> None:
    """Log each person's thumbnail from a good frame (``who/p<id>/thumbnail``, beside the 3D world: an image) and
    where it was cut (camera, frame, image box: ``who/p<id>``) into ``rec``, statically
    (:mod:`exporters.person_pictures`)."""
    for p, good in frames.items():
        track = int(result.track_ids[p])
        camera = result.cameras[good.camera].name
        x1, y1, x2, y2 = good.box
        text = (
            f"p{track}: best seen by {camera} in frame {good.frame}, image box {x1:.0f},{y1:.0f}-{x2:.0f},{y2:.0f} px"
        )
        rec.log(f"who/p{track}", rr.TextDocument(text), static=True)
        if p in pictures:
            rec.log(f"who/p{track}/thumbnail", rr.Image(pictures[p]), static=True)
