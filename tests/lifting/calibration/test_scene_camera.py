"""The camera from the scene's lines: synthetic rooms and pitches of known camera, the bundled lab cameras against
their calibration, and the fallbacks (no lines, a wall seen square on, a moving camera, no line detector)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from platypose.detectors.sources import scene_frames
from platypose.detectors.sources.scene_frames import sample_frames, video_scene_camera
from platypose.lifting.calibration import load_calibration
from platypose.lifting.calibration.pose_above_floor import intrinsics, pose_of
from platypose.lifting.calibration.scene import distortion, estimate
from platypose.lifting.calibration.scene.estimate import NO_DETECTOR, NOT_MEASURED, scene_camera
from platypose.lifting.calibration.scene.lines import to_lines
from platypose.lifting.calibration.scene.segments import content_mask, people_mask, person_boxes, unmasked_pieces
from platypose.lifting.calibration.scene.spread import physical_lines
from tests.line_scenes import pitch_markings, render, room

BALANCING = "data/video/pose2sim-balancing"


@pytest.mark.parametrize(
    ("scene", "roll", "pitch", "focal", "yaw", "height"),
    [
        ("room", 0.0, 15.0, 1500.0, 25.0, 1.8),
        ("room", 12.0, 30.0, 900.0, -20.0, 1.8),
        ("room", -25.0, 8.0, 2100.0, 35.0, 1.8),
        ("pitch", 3.0, 20.0, 1800.0, 20.0, 15.0),
        ("pitch", -8.0, 12.0, 3000.0, -25.0, 15.0),
    ],
)
def test_a_drawn_scene_gives_its_camera(scene, roll, pitch, focal, yaw, height):
    image = render(room() if scene == "room" else pitch_markings(), pitch, roll, focal, yaw, height)
    found = scene_camera([image])
    assert found.problem is None and found.focal_note is None
    assert abs(found.roll_deg - roll) < 1.0
    assert abs(found.pitch_deg - pitch) < 1.0
    assert abs(found.focal_px / focal - 1) < 0.05
    assert found.source["focal_px"] == estimate.FOCAL_SOURCE
    assert found.distortion == 0.0 and "distortion" not in found.source


@pytest.mark.parametrize(
    ("scene", "roll", "pitch", "focal", "yaw", "height", "k1"),
    [
        ("room", 12.0, 30.0, 900.0, -20.0, 1.8, -0.2),  # a wide lens's barrel: the pitch came out 10 degrees off
        ("room", 5.0, 15.0, 1200.0, 25.0, 1.8, -0.25),
        ("pitch", 3.0, 20.0, 1000.0, 20.0, 15.0, -0.2),  # 7 degrees off
        ("room", -10.0, 12.0, 1000.0, -30.0, 1.8, 0.08),  # pincushion
    ],
)
def test_a_scene_through_a_bending_lens_gives_its_camera_and_its_distortion(scene, roll, pitch, focal, yaw, height, k1):
    """Edges bent by a radial distortion (OpenCV's k1): roll and pitch within 1 degree and the focal length within
    5 % once the lines are straightened; the distortion found bends the same way, and the camera it gives
    (:func:`platypose.lifting.calibration.scene.distortion.opencv_coefficients`) puts every ray within 4 % of the
    image's diagonal of where the true lens does (the focal length's error and the division model's fit of a
    polynomial lens at the image's edge)."""
    image = render(room() if scene == "room" else pitch_markings(), pitch, roll, focal, yaw, height, distortion=k1)
    found = scene_camera([image])
    assert found.problem is None and found.focal_note is None
    assert abs(found.roll_deg - roll) < 1.0
    assert abs(found.pitch_deg - pitch) < 1.0
    assert abs(found.focal_px / focal - 1) < 0.05
    assert np.sign(found.distortion) == np.sign(k1) and found.source["distortion"] == distortion.SOURCE
    # rays through the camera found and through the true lens: the same pixels, within the focal length's error
    size = image.shape
    rays = np.stack(np.meshgrid(np.linspace(-1, 1, 11), np.linspace(-0.6, 0.6, 7)), -1).reshape(-1, 2)
    rays = rays[(rays**2).sum(1) < (0.95 / (-3 * k1) if k1 < 0 else np.inf)]
    truth = intrinsics(focal, size)[:2, 2] + focal * rays * (1 + k1 * (rays**2).sum(1, keepdims=True))
    rays = rays[(truth >= 0).all(1) & (truth[:, 0] < size[1]) & (truth[:, 1] < size[0])]
    truth = intrinsics(focal, size)[:2, 2] + focal * rays * (1 + k1 * (rays**2).sum(1, keepdims=True))
    coefficients = distortion.opencv_coefficients(found.distortion, size, found.focal_px)
    points = np.column_stack([rays, np.ones(len(rays))])
    mine = cv2.projectPoints(points, np.zeros(3), np.zeros(3), intrinsics(found.focal_px, size), coefficients)[0][:, 0]
    # 88 px: the focal length's 5 % alone moves the image's edge 55 px; without the distortion it is 150-220 px off
    assert np.abs(mine - truth).max() < 0.04 * np.hypot(*size)


def test_a_black_border_is_not_a_vertical():
    """Pillarbox columns: their edges are long upright lines that would pull the vertical point to infinity
    (unmasked here: pitch 1 degree off, focal length +25 %)."""
    image = render(pitch_markings(), 3.0, 20.0, 1800.0, 20.0, 15.0)
    image[:, :200] = 0
    image[:, -200:] = 0
    inside = content_mask(image)
    assert not inside[:, :204].any() and inside[:, 204:-204].all()
    found = scene_camera([image])
    assert abs(found.pitch_deg - 3.0) < 0.5 and abs(found.roll_deg - 20.0) < 0.5
    assert abs(found.focal_px / 1800.0 - 1) < 0.05


@pytest.fixture(scope="module")
def calibration():
    return load_calibration(f"{BALANCING}/calib_pose2sim.toml")


@pytest.mark.parametrize("view", ["cam01", "cam02", "cam03", "cam04"])
def test_the_lab_cameras_within_the_targets(calibration, view):
    """Pitch and roll within 2 degrees, focal length within 10 %, from 8 frames of each bundled lab camera
    (cam01 and cam04 rolled 13 and 26 degrees)."""
    truth = pose_of(calibration.camera(view.replace("cam", "cam_")))
    found = video_scene_camera(f"{BALANCING}/{view}.mp4", count=8)
    assert found.problem is None, found.problem
    assert abs(found.pitch_deg - truth["pitch_deg"]) < 2.0
    assert abs(found.roll_deg - truth["roll_deg"]) < 2.0
    assert abs(found.focal_px / truth["focal_px"] - 1) < 0.10
    assert found.distortion == 0.0  # the rig's lenses: k1 under 0.003


@pytest.mark.parametrize(("view", "k"), [("cam03", -0.4), ("cam02", 0.1)])
def test_a_lab_camera_seen_through_a_bending_lens_within_the_targets(calibration, view, k):
    """Real frames of a calibrated camera bent by a known lens (a barrel that at k = -0.4, zoomed 1.67 times to
    fill the frame, made cam03's pitch 30 degrees off; a pincushion): the distortion found within 0.03, pitch and
    roll within 2 degrees of the rig's, the focal length within 10 % of the rig's times the zoom."""
    truth = pose_of(calibration.camera(view.replace("cam", "cam_")))
    _, frames = sample_frames(f"{BALANCING}/{view}.mp4", 8)
    bent = [distortion.bent_image(frame, k) for frame in frames]
    found = scene_camera([image for image, _ in bent])
    assert abs(found.distortion - k) < 0.03
    assert abs(found.pitch_deg - truth["pitch_deg"]) < 2.0 and abs(found.roll_deg - truth["roll_deg"]) < 2.0
    assert abs(found.focal_px / (truth["focal_px"] * bent[0][1]) - 1) < 0.10


def test_the_outdoor_demo_stands_level_with_its_buildings():
    """The sports2d demo: buildings, a box and a fence under trees, a hand-held phone on a tripod about level
    (its calibration is a guess, so the check is the buildings': upright within 3 degrees, no distortion found)."""
    found = video_scene_camera("data/video/sports2d-demo/demo.mp4", count=8)
    assert found.problem is None, found.problem
    assert abs(found.roll_deg) < 3.0 and abs(found.pitch_deg) < 5.0
    assert found.distortion == 0.0


def test_a_scene_without_lines_falls_back():
    rng = np.random.default_rng(0)
    wall = np.clip(120 + np.linspace(0, 30, 1920)[None] + rng.normal(0, 4, (1080, 1920)), 0, 255).astype(np.uint8)
    found = scene_camera([wall] * 3)
    assert found.problem == estimate.NO_LINES and found.pitch_deg is None


def test_a_level_camera_at_a_wall_does_not_measure_the_focal_length():
    """Tiles on a wall seen square on: every line is upright or level in the image, the vanishing points at
    infinity; roll and pitch are seen (zero), the focal length is not, and that is said."""
    tiles = [((x, 6.0, 0.0), (x, 6.0, 3.0)) for x in np.arange(-4.0, 4.1, 0.5)]
    tiles += [((-4.0, 6.0, z), (4.0, 6.0, z)) for z in np.arange(0.0, 3.1, 0.5)]
    found = scene_camera([render(tiles, 0.0, 0.0, 1400.0)])
    assert found.problem is None
    assert found.focal_px is None and found.focal_note.startswith(NOT_MEASURED)
    assert abs(found.pitch_deg) < 0.5 and abs(found.roll_deg) < 0.5
    assert "lens prior" in found.source["pitch_deg"]


@pytest.fixture(scope="module")
def lab_frames():
    return sample_frames(f"{BALANCING}/cam02.mp4", 12)[1]


def test_a_moving_camera_is_detected(lab_frames):
    """The same frames, panned a little more each frame (up to 60 px) and turned (up to 3 degrees)."""
    h, w = lab_frames[0].shape
    moved = []
    for k, frame in enumerate(lab_frames):
        turn = cv2.getRotationMatrix2D((w / 2, h / 2), 3.0 * k / len(lab_frames), 1.0)
        turn[0, 2] += 60.0 * k / len(lab_frames)
        moved.append(cv2.warpAffine(frame, turn, (w, h)))
    found = scene_camera(moved)
    assert found.problem is not None and found.problem.startswith("camera moves")
    assert scene_camera(lab_frames).problem is None  # the same frames unmoved


def test_without_a_line_detector_it_says_so(monkeypatch, lab_frames):
    monkeypatch.delattr(cv2, "createLineSegmentDetector")
    found = scene_camera(lab_frames[:2])
    assert found.problem == NO_DETECTOR and found.roll_deg is None


def test_people_who_stay_are_masked_and_passers_by_not():
    still = np.array([[100.0, 100.0, 0.9], [140.0, 300.0, 0.9]])
    boxes = [person_boxes(np.stack([still, still + [60.0 * k, 0.0, 0.0]])) for k in range(10)]
    mask = people_mask((400, 800), boxes)
    assert mask[200, 120] and not mask[200, 500]


def test_a_long_video_is_sampled_at_key_frames(monkeypatch):
    """Past SEQUENTIAL_FRAMES, frames come from seeks (the demo's 230 frames, the limit set to 50)."""
    monkeypatch.setattr(scene_frames, "SEQUENTIAL_FRAMES", 50)
    indices, frames = sample_frames("data/video/sports2d-demo/demo.mp4", 10)
    assert 1 <= len(frames) <= 10 and frames[0].shape == (994, 1768) and frames[0].dtype == np.uint8
    assert np.all(np.diff(indices) > 0)


@pytest.mark.parametrize("view", ["cam01", "cam02"])
def test_with_its_people_masked_a_lab_camera_is_within_the_targets(calibration, view):
    """The bundled OpenPose people masked. cam01: the platform's edges then outnumber the walls' among the
    upright-looking lines and meet above the image; the likeliest of the three directions found is the up.
    cam02: the person's box hides the back wall and the rails, the platform's right edge pulls the best supported
    vertical point a degree off, and from there the horizon's search found a scene with the focal length +33 %
    (at a 2 % standard deviation); the candidates' scene that explains the most line length is the right one."""
    from platypose.detectors.sources.keypoint_source import read_keypoints

    truth = pose_of(calibration.camera(view.replace("cam", "cam_")))
    people = read_keypoints(f"{BALANCING}/openpose-body25b/{view}_json").keypoints
    found = video_scene_camera(f"{BALANCING}/{view}.mp4", people)
    assert found.problem is None, found.problem
    assert abs(found.pitch_deg - truth["pitch_deg"]) < 2.0 and abs(found.roll_deg - truth["roll_deg"]) < 2.0
    assert abs(found.focal_px / truth["focal_px"] - 1) < 0.10


def test_two_scenes_on_one_image_widen_the_focal_lengths_uncertainty():
    """Two rooms seen by different cameras drawn on one image (focal lengths 1200 and 1900 px): each alone is
    recovered; together the bootstrap's draws tell the scenes apart less surely, and the standard deviation says so
    (before: 2 %, the floor) and covers the error."""
    first = render(room(), 15.0, 0.0, 1200.0, 25.0)
    second = render(room(), 20.0, 3.0, 1900.0, -30.0)
    assert abs(scene_camera([first]).focal_px / 1200.0 - 1) < 0.05
    found = scene_camera([np.maximum(first, second)])
    if found.focal_px is not None:
        relative = found.sd["focal_px"] / found.focal_px
        assert relative > 0.04
        assert min(abs(found.focal_px - truth) for truth in (1200.0, 1900.0)) < 2.0 * found.sd["focal_px"]
    else:
        assert found.focal_note.startswith(NOT_MEASURED) and found.sd["pitch_deg"] > 2.0


def test_the_pieces_of_one_edge_are_one_physical_line():
    segments = np.array([[100.0, 500.0, 400.0, 520.0], [700.0, 540.0, 1000.0, 560.0], [100.0, 600.0, 400.0, 620.0]])
    groups = physical_lines(to_lines(segments, (1080, 1920)))
    assert groups[0] == groups[1] != groups[2]


def test_a_segment_behind_a_box_keeps_its_ends():
    allowed = np.ones((100, 400), bool)
    allowed[:, 150:250] = False
    pieces = unmasked_pieces(np.array([[10.0, 50.0, 390.0, 50.0]]), allowed)
    assert len(pieces) == 2
    assert pieces[0, 0] == 10.0 and 140.0 < pieces[0, 2] < 150.0 and 250.0 <= pieces[1, 0] < 260.0


def test_a_camera_looking_up_is_said_to_look_up() -> None:
    """The log's words for a pitch: a negative pitch (the sports2d demo's scene: -2.4 degrees) reads "up", not
    "-2.4 degrees down"."""
    from platypose.lifting.calibration.pose_above_floor import pitched

    assert pitched(-2.4) == "pitched 2.4 degrees up"
    assert pitched(18.3, 0.3) == "pitched 18.3 +- 0.3 degrees down"


def test_the_straightest_distortion_is_the_scores_peak_and_a_small_gain_is_none():
    """The search climbs from k = 0 to the score's peak (a parabola's vertex, exact here) and calls the score once
    per k; a peak that explains under ``MIN_GAIN`` more than none is not taken."""
    calls = []

    def peaked(k: float) -> float:
        calls.append(k)
        return 0.9 - 2.0 * (k + 0.23) ** 2

    best, scores = distortion.straightest(peaked)
    assert abs(best + 0.23) < 1e-6 and len(calls) == len(set(calls)) == len(scores)
    assert distortion.straightest(lambda k: 0.8 - 2.0 * (k - 0.1) ** 2)[0] == 0.0  # gains 0.02
    pixels = np.array([[100.0, 50.0], [960.0, 540.0], [1800.0, 1000.0]])
    bent = distortion.undistort_pixels(pixels, (1080, 1920), -0.3)
    assert np.allclose(bent[1], pixels[1]) and np.linalg.norm(bent[0] - [960, 540]) > np.linalg.norm(
        pixels[0] - [960, 540]
    )
