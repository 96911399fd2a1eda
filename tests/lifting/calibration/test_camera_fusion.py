"""Each of roll, pitch and focal length fused from the sources that measure it (the scene's lines, the people's
verticals, the video's metadata), a source more than 3 sigma off dropped and said so: the fusion alone, the people's
verticals on synthetic people, a synthetic view whose people are 5 sigma off its lines, and the bundled lab cameras."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from platypose.lifting.calibration import load_calibration
from platypose.lifting.calibration.fusion import Estimate, fuse
from platypose.lifting.calibration.lens import METADATA
from platypose.lifting.calibration.people_vertical import MIN_FRAMES, people_vertical, standing_lines
from platypose.lifting.calibration.people_vertical import SOURCE as PEOPLE
from platypose.lifting.calibration.pose_above_floor import pose_of, posed_camera
from platypose.lifting.calibration.scene.distortion import undistort_pixels
from platypose.lifting.calibration.scene.estimate import FOCAL_SOURCE, VERTICAL_SOURCE, SceneCamera
from platypose.lifting.calibration.scene.view_camera import assumed_camera
from platypose.lifting.skeleton import JOINT_INDEX

BALANCING = "data/video/pose2sim-balancing"
SIZE = (1080, 1920)
TIMES = np.arange(30) / 30.0  # the people's 30 frames at 30 fps
LEGS = {"hip": 0.9, "knee": 0.5, "ankle": 0.1}  # heights (m) of a straight leg's joints


@pytest.fixture(scope="module")
def calibration():
    return load_calibration(f"{BALANCING}/calib_pose2sim.toml")


def standing_people(camera, places, frames: int = 30, lean_deg: float = 0.0, seed: int = 0) -> np.ndarray:
    """Keypoints (T, P, 17, 3) of people standing straight at floor ``places`` (P, 2) m seen by ``camera`` (legs
    only; the rest unseen), each leaning ``lean_deg`` at most in a random direction, with 1 px of noise."""
    rng = np.random.default_rng(seed)
    out = np.full((frames, len(places), 17, 3), np.nan)
    out[..., 2] = 0.0
    for p, (x, y) in enumerate(places):
        tilt = np.radians(lean_deg) * rng.uniform(-1, 1, 2)
        for side, dx in (("right", -0.1), ("left", 0.1)):
            for joint, z in LEGS.items():
                point = np.array([x + dx + tilt[0] * z, y + tilt[1] * z, z])
                cam = camera.R @ point + camera.t
                pixel = camera.K[:2, :2] @ (cam[:2] / cam[2]) + camera.K[:2, 2]
                index = JOINT_INDEX[f"{side}_{joint}"]
                out[:, p, index, :2] = pixel + rng.normal(0.0, 1.0, (frames, 2))
                out[:, p, index, 2] = 0.9
    return out


def test_agreeing_sources_are_their_inverse_variance_mean():
    fused = fuse([Estimate(10.0, 1.0, "a"), Estimate(12.0, 2.0, "b")])
    assert fused.value == pytest.approx((10.0 / 1 + 12.0 / 4) / (1 + 1 / 4))
    assert fused.sd == pytest.approx(1 / np.sqrt(1.25)) and not fused.dropped and fused.source == "a + b"


def test_a_source_five_sigma_off_the_others_is_dropped_with_why():
    good = [Estimate(1500.0, 30.0, METADATA), Estimate(1520.0, 30.0, FOCAL_SOURCE)]
    off = Estimate(1510.0 + 5 * np.hypot(40.0, 30.0 / np.sqrt(2)), 40.0, "people")
    fused = fuse([good[0], off, good[1]], " px")
    assert [e.source for e in fused.used] == [METADATA, FOCAL_SOURCE] and fused.value == pytest.approx(1510.0)
    (dropped, why), *rest = fused.dropped
    assert dropped is off and not rest and why.startswith("5.0 sigma off") and "1510.0 +- 21.2 px" in why


def test_of_two_that_disagree_the_less_trusted_goes():
    fused = fuse([Estimate(0.0, 0.3, VERTICAL_SOURCE), Estimate(4.0, 1.0, PEOPLE)])
    assert fused.value == 0.0 and [e.source for e in fused.dropped[0][:1]] == [PEOPLE]
    assert fuse([Estimate(0.0, 0.3, "a"), Estimate(2.0, 1.0, "b")]).dropped == ()  # 1.9 sigma: both kept


@pytest.mark.parametrize(("pitch", "roll"), [(20.0, 5.0), (35.0, -15.0), (8.0, 0.0)])
def test_people_standing_across_the_view_give_its_roll_and_pitch(pitch, roll):
    camera = posed_camera("v", SIZE, 1400.0, pitch, roll, 3.0)
    people = standing_people(camera, [(-3.0, 6.0), (0.0, 9.0), (3.5, 7.0), (1.5, 5.0)], lean_deg=0.5)
    found = people_vertical(people, TIMES, SIZE, 1400.0, (pitch, 0.0))  # the roll at the lines' pitch
    assert found.pitch_deg == pytest.approx(pitch, abs=1.5) and found.roll_deg == pytest.approx(roll, abs=0.5)
    assert people_vertical(people, TIMES, SIZE, 1400.0, (pitch + 10.0, 0.0)).pitch_deg == pytest.approx(pitch, abs=1.5)
    assert found.sd["roll_deg"] >= 0.9 * 2.0 / np.sqrt(4)  # each person's lean is not averaged out over frames
    assert found.frames == 4 * 30 and found.persons == 4


def test_one_person_in_one_place_gives_the_roll_only_and_bent_legs_or_walking_nothing():
    camera = posed_camera("v", SIZE, 1400.0, 20.0, 7.0, 2.0)
    found = people_vertical(standing_people(camera, [(0.5, 5.0)]), TIMES, SIZE, 1400.0, (20.0, 0.0))
    assert found.pitch_deg is None and found.roll_deg == pytest.approx(7.0, abs=0.5) and "pitch_deg" not in found.sd
    bent = standing_people(camera, [(0.5, 5.0)])
    bent[:, :, [JOINT_INDEX["right_knee"], JOINT_INDEX["left_knee"]], 0] += 60.0  # knees forward: bent legs
    assert people_vertical(bent, TIMES, SIZE, 1400.0) is None
    walking = standing_people(camera, [(0.5, 5.0)])
    walking[..., 0] += 5.0 * np.arange(30)[:, None, None]  # 150 px a second, the hips 205 px up: not still
    assert people_vertical(walking, TIMES, SIZE, 1400.0) is None


def test_people_five_sigma_off_the_lines_are_dropped_and_said_once():
    """The scene's lines say rolled 2 degrees; the people stand in a camera rolled 5 sigma further (their roll's
    and the lines' spreads combined): the people's roll is dropped, the log says so once, meta names it and why."""
    places = [(-2.0, 6.0), (2.0, 8.0)]
    lines_sd = 0.3
    level = people_vertical(
        standing_people(posed_camera("v", SIZE, 1500.0, 15.0, 2.0, 2.5), places), TIMES, SIZE, 1500.0
    )
    off = 2.0 + 5.0 * np.hypot(level.sd["roll_deg"], lines_sd)
    people = standing_people(posed_camera("v", SIZE, 1500.0, 15.0, off, 2.5), places)
    scene = SceneCamera(
        roll_deg=2.0,
        pitch_deg=15.0,
        focal_px=1500.0,
        sd={"roll_deg": lines_sd, "pitch_deg": 0.3, "focal_px": 30.0},
        source={"roll_deg": VERTICAL_SOURCE, "pitch_deg": VERTICAL_SOURCE, "focal_px": FOCAL_SOURCE},
        segments=90,
        focal_at=1500.0,
    )
    found = assumed_camera("v", SIZE, scene, people=(people, TIMES))
    roll = found.record["roll_deg"]
    assert roll["value"] == 2.0 and roll["source"] == VERTICAL_SOURCE
    (dropped,) = roll["dropped"]
    assert dropped["source"] == PEOPLE and dropped["value"] == pytest.approx(off, abs=0.5)
    assert float(dropped["why"].split(" sigma")[0]) == pytest.approx(5.0, abs=1.0)
    said = [line for line in found.lines if "dropped" in line]
    assert len(said) == 1 and said[0].startswith(f"roll: {PEOPLE}")
    assert pose_of(found.camera)["roll_deg"] == pytest.approx(2.0)


def lines_scene(**changes) -> SceneCamera:
    """The scene's lines of a camera pitched 15 and rolled 2 degrees, 1500 px (spreads 0.3 degrees and 30 px),
    with ``changes``."""
    scene = {
        "roll_deg": 2.0,
        "pitch_deg": 15.0,
        "focal_px": 1500.0,
        "sd": {"roll_deg": 0.3, "pitch_deg": 0.3, "focal_px": 30.0},
        "source": {"roll_deg": VERTICAL_SOURCE, "pitch_deg": VERTICAL_SOURCE, "focal_px": FOCAL_SOURCE},
        "focal_at": 1500.0,
    }
    return SceneCamera(**{**scene, **changes})


def test_the_lines_pitch_follows_a_focal_length_fused_with_the_metadata():
    """Metadata 1600 px (5 %) and lines 1500 +- 30 px agree (1.3 sigma): the fused focal length is their
    inverse-variance mean, and the lines' pitch moves along its slope to it."""
    scene = lines_scene(roll_deg=0.0, pitch_slope=4.0)
    found = assumed_camera("v", SIZE, scene, metadata_focal=1600.0)
    focal = found.record["focal_px"]
    expected = (1600.0 / 80.0**2 + 1500.0 / 30.0**2) / (1 / 80.0**2 + 1 / 30.0**2)
    assert focal["value"] == pytest.approx(expected) and not focal["dropped"] and len(focal["used"]) == 2
    assert found.record["pitch_deg"]["value"] == pytest.approx(15.0 + 4.0 * np.log(expected / 1500.0))


@pytest.mark.parametrize("view", ["cam01", "cam02", "cam03", "cam04"])
def test_the_lab_cameras_fused_with_their_people_stay_within_the_targets(calibration, view):
    """The bundled OpenPose people mask the scene and check its roll and pitch; the fused camera stays within 2
    degrees and 10 % of the rig, and the people's say is used or dropped with why where they stand still enough."""
    from platypose.detectors.sources.keypoint_source import read_keypoints
    from platypose.detectors.sources.scene_frames import video_scene_camera

    truth = pose_of(calibration.camera(view.replace("cam", "cam_")))
    people = read_keypoints(f"{BALANCING}/openpose-body25b/{view}_json")
    scene = video_scene_camera(f"{BALANCING}/{view}.mp4", people.keypoints)
    found = assumed_camera(view, people.image_size, scene, people=(people.keypoints, people.frame_times))
    used = pose_of(found.camera)
    assert abs(used["pitch_deg"] - truth["pitch_deg"]) < 2.0 and abs(used["roll_deg"] - truth["roll_deg"]) < 2.0
    assert abs(used["focal_px"] / truth["focal_px"] - 1) < 0.10
    roll = found.record["roll_deg"]
    said = [e["source"] for e in roll["used"]] + [e["source"] for e in roll["dropped"]]
    still = len(standing_lines(people.keypoints, people.frame_times)[0]) >= MIN_FRAMES  # cam03's athlete never is
    assert said[0] == VERTICAL_SOURCE and (PEOPLE in said) == still
    assert still or "stand still" in found.record["people"]["note"]
    assert all("sigma off" in e["why"] for e in roll["dropped"])


def test_the_scenes_lens_distortion_is_on_the_camera_and_said():
    """A scene straightened by the division model's k = -0.3 (a wide lens's barrel): the camera carries OpenCV
    coefficients that bend a ray to the pixel the model undistorts from (within 2 px across the image), meta and
    the log say it; the people's keypoints are undistorted before they check the lines' roll (a camera rolled 2
    degrees: not dropped)."""
    scene = lines_scene(distortion=-0.3)
    camera = posed_camera("v", SIZE, 1500.0, 15.0, 2.0, 2.5)
    people = standing_people(camera, [(-2.0, 6.0), (2.0, 8.0)])
    seen = people.copy()  # the same people through the lens: each pixel where the model bends it
    seen[..., :2] = _division_distort(people[..., :2], SIZE, -0.3)
    found = assumed_camera("v", SIZE, scene, people=(seen, TIMES))
    assert found.record["distortion"]["value"] == -0.3 and np.any(found.camera.dist[5:] != 0)  # the rational model
    assert any("lens distortion k = -0.30" in line for line in found.lines)
    assert not found.record["roll_deg"]["dropped"]
    grid = np.stack(np.meshgrid(np.linspace(20, SIZE[1] - 20, 9), np.linspace(20, SIZE[0] - 20, 7)), -1).reshape(-1, 2)
    straight = undistort_pixels(grid, SIZE, -0.3)
    rays = np.linalg.solve(found.camera.K, np.column_stack([straight, np.ones(len(grid))]).T).T
    bent = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), found.camera.K, found.camera.dist)[0][:, 0]
    assert np.abs(bent - grid).max() < 2.0


def _division_distort(pixels: np.ndarray, size: tuple[int, int], k: float) -> np.ndarray:
    """Pixels (..., 2) bent by the division model's ``k`` (the inverse of ``undistort_pixels``, by bisection on
    the radius)."""
    centre = np.array([size[1], size[0]], np.float64) / 2
    scale = np.hypot(*size) / 2
    straight = (pixels - centre) / scale
    radius = np.linalg.norm(straight, axis=-1, keepdims=True)
    low, high = np.zeros_like(radius), np.full_like(radius, 1.5)
    for _ in range(60):
        middle = (low + high) / 2
        too_far = middle / (1 + k * middle**2) > radius
        high, low = np.where(too_far, middle, high), np.where(too_far, low, middle)
    ratio = np.where(radius > 0, low / np.maximum(radius, 1e-12), 1.0)
    return straight * ratio * scale + centre
