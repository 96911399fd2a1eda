"""The estimated camera's horizon: where points at the camera's height are seen (checked against OpenCV's
projection), drawn into a person's picture where it crosses it (read back with OpenCV), the picture stretched to
it where it is near, and the caption that names each quantity's value, spread and source."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from platypose.exporters.horizon import (
    HORIZON_RGB,
    camera_caption,
    clip_line,
    draw_horizon,
    horizon_curve,
    horizon_line,
    horizon_place,
    in_thumbnail,
    reach_horizon,
)
from platypose.exporters.person_pictures import crop
from platypose.lifting.calibration.pose_above_floor import posed_camera

SIZE = (1080, 1920)


def seen(camera, points: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) of world ``points`` (N, 3) by OpenCV's projection."""
    rvec = cv2.Rodrigues(np.asarray(camera.R, np.float64))[0]
    pixels, _ = cv2.projectPoints(points, rvec, np.asarray(camera.t, np.float64), np.asarray(camera.K), None)
    return pixels.reshape(-1, 2)


def far_at_height(height: float) -> np.ndarray:
    """Points (N, 3) 1 km in front of a camera looking along +y, spread across, at ``height``."""
    return np.array([[x, 1000.0, height] for x in np.linspace(-300.0, 300.0, 7)])


def magenta(image_bgr: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) (x, y) of an OpenCV BGR image in the horizon's colour."""
    r, g, b = HORIZON_RGB
    ys, xs = np.nonzero(np.all(image_bgr == (b, g, r), axis=-1))
    return np.column_stack([xs, ys]).astype(float)


@pytest.mark.parametrize(("pitch", "roll"), [(10.0, 8.0), (-3.0, 0.0), (25.0, -20.0)])
def test_the_horizon_is_where_the_camera_sees_points_at_its_height(pitch, roll):
    camera = posed_camera("v", SIZE, 1400.0, pitch, roll, 1.6)
    line = horizon_line(camera.K, camera.R)
    pixels = seen(camera, far_at_height(1.6))
    distance = pixels @ line[:2] + line[2]
    assert np.abs(distance).max() < 1.0  # 1 km away: within a pixel of the vanishing line
    below = seen(camera, np.array([[0.0, 5.0, 0.0]]))[0] @ line[:2] + line[2]
    above = seen(camera, np.array([[0.0, 5.0, 3.0]]))[0] @ line[:2] + line[2]
    assert np.sign(below) == -np.sign(above)


def test_a_person_picture_shows_the_horizon_where_it_crosses_and_cv2_reads_it_back(tmp_path):
    camera = posed_camera("v", SIZE, 1400.0, 12.0, 9.0, 2.0)
    line = horizon_line(camera.K, camera.R)
    image = np.full((*SIZE, 3), 120, np.uint8)
    horizon_y = -(line[0] * 900 + line[2]) / line[1]
    box = (800.0, horizon_y - 100.0, 1000.0, horizon_y + 400.0)  # the horizon crosses its top fifth
    picture = crop(image, box)
    drawn = draw_horizon(picture, in_thumbnail(horizon_curve(camera), box, picture.shape))
    assert np.array_equal(picture, np.full_like(picture, 120))  # the picture given is not drawn on
    cv2.imwrite(str(tmp_path / "p.png"), cv2.cvtColor(drawn, cv2.COLOR_RGB2BGR))
    found = magenta(cv2.imread(str(tmp_path / "p.png")))
    assert len(found) >= picture.shape[1]  # a line from side to side, HORIZON_PX wide
    x1, y1, x2, y2 = (int(round(v)) for v in box)  # the picture's pixels in the image's, as crop spreads them
    full = np.column_stack(
        [
            x1 + found[:, 0] * (x2 - x1 - 1) / (picture.shape[1] - 1),
            y1 + found[:, 1] * (y2 - y1 - 1) / (picture.shape[0] - 1),
        ]
    )
    far = seen(camera, far_at_height(2.0))
    slope = np.polyfit(far[:, 0], far[:, 1], 1)
    step = (y2 - y1 - 1) / (picture.shape[0] - 1)
    assert np.abs(np.polyval(slope, full[:, 0]) - full[:, 1]).max() < 2.5 * step
    assert 0.1 < found[:, 1].mean() / picture.shape[0] < 0.3


def test_a_picture_is_stretched_to_a_horizon_near_it_and_not_to_a_far_one():
    camera = posed_camera("v", SIZE, 1400.0, 15.0, 0.0, 2.0)
    line = horizon_line(camera.K, camera.R)
    horizon_y = -line[2] / line[1]
    near = (800.0, horizon_y + 100.0, 1000.0, horizon_y + 500.0)
    curve = horizon_curve(camera)
    stretched = reach_horizon(curve, near, SIZE)
    assert stretched[1] < horizon_y and stretched[1] > horizon_y - 5 and stretched[3] == near[3]
    far = (800.0, horizon_y + 300.0, 1000.0, horizon_y + 500.0)  # 300 px away, the box 200 px high
    assert reach_horizon(curve, far, SIZE) == far
    picture = crop(np.zeros((*SIZE, 3), np.uint8), far)
    assert horizon_place(in_thumbnail(curve, far, picture.shape), picture.shape) == "above"
    assert horizon_place(in_thumbnail(curve, near, picture.shape), picture.shape) == "above"
    assert horizon_place(in_thumbnail(curve, stretched, picture.shape), picture.shape) is None
    assert clip_line(np.array([0.0, 1.0, 10.0]), 100.0, 50.0) is None  # y = -10: above a 100 x 50 image


def test_through_a_barrel_lens_the_horizon_bends_where_the_camera_sees_points_at_its_height(tmp_path):
    """A wide lens (the scene's distortion k = -0.4 as OpenCV's rational model): the horizon is a curve through
    where OpenCV projects points 1 km away at the camera's height (within a pixel), bowed 20 px and more off its
    chord, and it is drawn so (read back with OpenCV: every drawn pixel within 2 px of the curve)."""
    from dataclasses import replace

    from platypose.lifting.calibration.scene.distortion import opencv_coefficients

    straight = posed_camera("v", SIZE, 1100.0, 20.0, 6.0, 1.6)
    camera = replace(straight, dist=opencv_coefficients(-0.4, SIZE, 1100.0))
    curve = horizon_curve(camera)
    rvec = cv2.Rodrigues(camera.R)[0]
    far = np.array([[x, 1000.0, 1.6] for x in np.linspace(-600.0, 600.0, 25)])
    pixels = cv2.projectPoints(far, rvec, camera.t, camera.K, camera.dist)[0][:, 0]
    pixels = pixels[(pixels >= 0).all(1) & (pixels[:, 0] < SIZE[1]) & (pixels[:, 1] < SIZE[0])]
    assert len(pixels) >= 10
    dense = np.concatenate([np.linspace(a, b, 50) for a, b in zip(curve[:-1], curve[1:])])
    assert np.linalg.norm(pixels[:, None] - dense[None], axis=-1).min(axis=1).max() < 1.0
    chord = curve[-1] - curve[0]
    rel = curve - curve[0]
    off = np.abs(chord[0] * rel[:, 1] - chord[1] * rel[:, 0]) / np.linalg.norm(chord)
    assert off.max() > 20.0
    picture = draw_horizon(np.full((*SIZE, 3), 120, np.uint8), curve)
    cv2.imwrite(str(tmp_path / "h.png"), cv2.cvtColor(picture, cv2.COLOR_RGB2BGR))
    drawn = magenta(cv2.imread(str(tmp_path / "h.png")))
    assert len(drawn) >= SIZE[1] and np.linalg.norm(drawn[:, None] - dense[None], axis=-1).min(axis=1).max() < 2.0


def test_the_caption_names_each_quantity_with_its_spread_source_and_what_was_dropped():
    entry = {"value": 2.04, "sd": 0.3, "source": "scene lines", "used": [], "dropped": []}
    dropped = {"value": 9.1, "sd": 1.2, "source": "people", "why": "5.6 sigma off scene lines (2.0 +- 0.3 degrees)"}
    meta = {
        "camera": {
            "roll_deg": {**entry, "dropped": [dropped]},
            "pitch_deg": {**entry, "value": 15.52},
            "focal_px": {"value": 1531.0, "sd": None, "source": "lens prior"},
            "height_m": {"source": "people"},
            "focal_note": "focal length not measured: too few lines",
        },
        "floor": {"camera_height_m": 1.874},
    }
    assert camera_caption(meta) == [
        "roll 2.0 +- 0.3 deg (scene lines)",
        "  roll from people (9.1 +- 1.2) dropped: 5.6 sigma off scene lines (2.0 +- 0.3 degrees)",
        "pitch (down) 15.5 +- 0.3 deg (scene lines)",
        "focal 1531 px (lens prior)",
        "focal length not measured: too few lines",
        "height 1.87 m (people)",
    ]
    assert camera_caption({}) == []
