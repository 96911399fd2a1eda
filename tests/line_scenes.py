"""Synthetic line drawings for the camera from the scene: a room's or a sports pitch's straight edges, seen by a
camera of known pitch, roll and focal length, drawn with ``cv2.line`` on a blank grey image."""

from __future__ import annotations

import cv2
import numpy as np

from platypose.lifting.calibration.pose_above_floor import posed_camera


def _box(x: float, y: float, width: float, depth: float, height: float) -> list[tuple[tuple, tuple]]:
    """The 12 edges of an upright box with a floor corner at (x, y)."""
    corners = [(x + a * width, y + b * depth, c * height) for a in (0, 1) for b in (0, 1) for c in (0, 1)]
    return [(p, q) for i, p in enumerate(corners) for q in corners[i + 1 :] if sum(u != v for u, v in zip(p, q)) == 1]


def room() -> list[tuple[tuple, tuple]]:
    """A floor tiled in 1 m squares, cupboards, a table and door frames in front of a camera at the origin."""
    edges = [((x, 1.0, 0.0), (x, 12.0, 0.0)) for x in range(-6, 7, 2)]
    edges += [((-6.0, y, 0.0), (6.0, y, 0.0)) for y in range(2, 13, 2)]
    for x, y, w, d, h in [
        (-4, 6, 1.2, 0.6, 2.0),
        (2.5, 7, 1.0, 0.8, 1.8),
        (-1, 4, 1.6, 0.9, 0.75),
        (1, 10, 2, 0.5, 2.4),
    ]:
        edges += _box(x, y, w, d, h)
    for x in (-2.5, 3.5):  # door frames on the far wall
        edges += [((x, 12.0, 0.0), (x, 12.0, 2.1)), ((x + 0.9, 12.0, 0.0), (x + 0.9, 12.0, 2.1))]
        edges += [((x, 12.0, 2.1), (x + 0.9, 12.0, 2.1))]
    return edges


def pitch_markings() -> list[tuple[tuple, tuple]]:
    """A football pitch's lines (105 x 68 m, its near touchline 8 m ahead), goals and floodlight masts."""
    y0, x0 = 8.0, -52.5
    edges = [((x0, y0, 0.0), (-x0, y0, 0.0)), ((x0, y0 + 68, 0.0), (-x0, y0 + 68, 0.0))]
    edges += [((x, y0, 0.0), (x, y0 + 68, 0.0)) for x in (x0, 0.0, -x0)]
    for side in (-1, 1):  # penalty areas and goals
        line = side * 52.5
        edges += [((line, y0 + 13.85, 0.0), (line - side * 16.5, y0 + 13.85, 0.0))]
        edges += [((line, y0 + 54.15, 0.0), (line - side * 16.5, y0 + 54.15, 0.0))]
        edges += [((line - side * 16.5, y0 + 13.85, 0.0), (line - side * 16.5, y0 + 54.15, 0.0))]
        edges += [
            ((line, y0 + 30.34, 0.0), (line, y0 + 30.34, 2.44)),
            ((line, y0 + 37.66, 0.0), (line, y0 + 37.66, 2.44)),
        ]
        edges += [((line, y0 + 30.34, 2.44), (line, y0 + 37.66, 2.44))]
    for x in (-60.0, -20.0, 20.0, 60.0):  # masts and stand pillars behind the far touchline
        edges += [((x, y0 + 80, 0.0), (x, y0 + 80, 30.0))]
    for x in range(-50, 51, 10):
        edges += [((float(x), y0 + 72, 0.0), (float(x), y0 + 72, 8.0))]
    edges += [((-55.0, y0 + 72, 8.0), (55.0, y0 + 72, 8.0))]
    return edges


def render(
    edges: list[tuple[tuple, tuple]],
    pitch: float,
    roll: float,
    focal: float,
    yaw: float = 0.0,
    height: float = 1.8,
    size: tuple[int, int] = (1080, 1920),
    distortion: float = 0.0,
) -> np.ndarray:
    """The ``edges`` (world points, m) turned ``yaw`` degrees about the camera's vertical, drawn as 2 px lines on a
    grey image (H, W) uint8 seen by the camera ``height`` m up, pitched, rolled, of ``focal`` px; with OpenCV's
    radial ``distortion`` k1 (radii over the focal length), each edge bent by it."""
    camera = posed_camera("scene", size, focal, pitch, roll, height)
    c, s = np.cos(np.radians(yaw)), np.sin(np.radians(yaw))
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    image = np.full(size, 40, np.uint8)
    if distortion:
        _draw_bent(image, edges, camera, turn, distortion)
        return image
    for p, q in edges:
        a, b = (camera.R @ (turn @ np.array(p, float)) + camera.t, camera.R @ (turn @ np.array(q, float)) + camera.t)
        if a[2] < 0.2 and b[2] < 0.2:
            continue
        if a[2] < 0.2 or b[2] < 0.2:  # clip to in front of the camera
            k = (0.2 - a[2]) / (b[2] - a[2])
            a, b = (a + k * (b - a), b) if a[2] < 0.2 else (a, a + k * (b - a))
        u, v = (camera.K @ (a / a[2]))[:2], (camera.K @ (b / b[2]))[:2]
        ok, start, end = cv2.clipLine(
            (0, 0, size[1], size[0]), tuple(int(round(w)) for w in u), tuple(int(round(w)) for w in v)
        )
        if ok:
            cv2.line(image, start, end, 220, 2, cv2.LINE_AA)
    return image


def _draw_bent(image: np.ndarray, edges, camera, turn: np.ndarray, k1: float) -> None:
    """Each edge sampled at 200 points, projected with OpenCV's radial distortion ``k1`` and drawn as a polyline
    (a barrel lens's points past where its distortion folds back are left out, as no lens shows them)."""
    height, width = image.shape
    for p, q in edges:
        points = np.linspace(np.array(p, float), np.array(q, float), 200) @ turn.T @ camera.R.T + camera.t
        points = points[points[:, 2] > 0.2]
        ratios = points[:, :2] / points[:, 2:]
        radius2 = (ratios**2).sum(axis=1, keepdims=True)
        if k1 < 0:
            keep = radius2[:, 0] < 0.95 / (-3 * k1)
            ratios, radius2 = ratios[keep], radius2[keep]
        pixels = ratios * (1 + k1 * radius2) * camera.K[0, 0] + camera.K[:2, 2]
        pixels = pixels[(pixels >= 0).all(axis=1) & (pixels[:, 0] < width) & (pixels[:, 1] < height)]
        if len(pixels) >= 2:
            cv2.polylines(image, [np.round(pixels * 16).astype(np.int32)[:, None]], False, 220, 2, cv2.LINE_AA, shift=4)
