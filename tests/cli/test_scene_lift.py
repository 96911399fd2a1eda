"""A lift without ``--cams`` stands on the camera of its scene's lines (roll, pitch, focal length; the height from
the people), says which source gave each once, and ``calib estimate`` writes that camera for ``--cams``."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

import platypose
from platypose.lifting.calibration import load_calibration
from platypose.lifting.calibration.defaults import LEVEL_R
from platypose.lifting.calibration.lens import METADATA, PRIOR, prior_focal
from platypose.lifting.calibration.pose_above_floor import pose_of
from platypose.lifting.calibration.scene.estimate import FOCAL_SOURCE, NOT_MEASURED, VERTICAL_SOURCE, SceneCamera
from platypose.lifting.calibration.scene.view_camera import FALLBACK, assumed_camera
from platypose.lifting.tracks.quick_floor import FLOOR_PASS_SAMPLES

BALANCING = "video/pose2sim-balancing"
SETTINGS = {"persons": "largest", "samples": FLOOR_PASS_SAMPLES}  # calib estimate's quick lift, as a lift's


@pytest.fixture
def tiny_default_prior(monkeypatch, prior_file):
    """The tiny prior in place of the shipped one (calib estimate loads the default)."""
    import platypose.lifting.prior.model as prior_module

    monkeypatch.setattr(prior_module, "DEFAULT_PRIOR", Path(prior_file))
    return prior_file


def test_a_lift_without_cams_uses_the_scene_and_calib_estimate_gives_it_back(
    tiny_default_prior, data_dir, tmp_path, run_cli
):
    """cam02 (on main: pitch 9.7 degrees off, focal length +32 %): the scene's roll, pitch and focal length within
    the issue's targets; the file calib estimate writes gives the same camera back through --cams."""
    video = data_dir / BALANCING / "cam02.mp4"
    truth = pose_of(load_calibration(data_dir / BALANCING / "calib_pose2sim.toml").camera("cam_02"))
    lifted = platypose.lift(video, **SETTINGS)
    used = pose_of(lifted.cameras[0])
    assert abs(used["pitch_deg"] - truth["pitch_deg"]) < 2.0 and abs(used["roll_deg"] - truth["roll_deg"]) < 2.0
    assert abs(used["focal_px"] / truth["focal_px"] - 1) < 0.10
    record = lifted.meta["camera"]
    assert record["pitch_deg"]["used"][0]["source"] == VERTICAL_SOURCE and record["focal_px"]["source"] == FOCAL_SOURCE
    assert record["pitch_deg"]["value"] == pytest.approx(used["pitch_deg"], abs=1e-6)
    assert sum("camera from the scene's lines" in note for note in lifted.meta["notes"]) == 1
    assert "estimated world" in lifted.meta["floor"]["frame"]

    out = tmp_path / "calib.toml"
    code, stdout, stderr = run_cli("calib", "estimate", video, "--persons", "largest", "--out", out)
    assert code == 0, stderr
    assert "wrote" in stdout and "camera from the scene's lines" in out.read_text()
    back = platypose.lift(video, cams=out, **SETTINGS)
    assert back.meta["floor"]["source"] == "calibration"
    assert np.allclose(back.cameras[0].R, lifted.cameras[0].R, atol=1e-9)
    assert np.allclose(back.cameras[0].center, lifted.cameras[0].center, atol=1e-3)
    assert np.allclose(back.cameras[0].K, lifted.cameras[0].K, atol=1e-6)


def test_keypoints_with_their_video_beside_them_stand_on_its_scene(tiny_default_prior, data_dir, tmp_path):
    """cam02's OpenPose folder with cam02.mp4 one folder up (as the bundled take is laid out): the scene's camera,
    as for the video; the same folder alone (fps and size given) has no scene to see: the level camera of before."""
    take = tmp_path / "take"
    shutil.copytree(data_dir / BALANCING / "openpose-body25b" / "cam02_json", take / "openpose" / "cam02_json")
    shutil.copy(data_dir / BALANCING / "cam02.mp4", take / "cam02.mp4")
    truth = pose_of(load_calibration(data_dir / BALANCING / "calib_pose2sim.toml").camera("cam_02"))
    lifted = platypose.lift(take / "openpose" / "cam02_json", **SETTINGS)
    used = pose_of(lifted.cameras[0])
    assert abs(used["pitch_deg"] - truth["pitch_deg"]) < 2.0 and abs(used["roll_deg"] - truth["roll_deg"]) < 2.0
    assert sum("camera from the scene's lines" in note for note in lifted.meta["notes"]) == 1
    (take / "cam02.mp4").unlink()
    alone = platypose.lift(take / "openpose" / "cam02_json", fps=60.0, image_size=(1920, 1080), **SETTINGS)
    assert not any("camera from the scene's lines" in note for note in alone.meta["notes"])


def test_without_a_line_detector_the_lift_falls_back_and_says_so(tiny_default_prior, data_dir, monkeypatch):
    monkeypatch.delattr(cv2, "createLineSegmentDetector")
    lifted = platypose.lift(data_dir / BALANCING / "cam02.mp4", **SETTINGS)
    said = [note for note in lifted.meta["notes"] if FALLBACK in note]
    assert len(said) == 1 and "no line detector" in said[0]
    assert lifted.meta["camera"]["scene"].startswith("no line detector")
    assert "(the scene)" not in " ".join(lifted.meta["notes"])


SCENE = {"roll_deg": 2.0, "pitch_deg": 15.0, "segments": 80}
SOURCES = {"roll_deg": VERTICAL_SOURCE, "pitch_deg": VERTICAL_SOURCE}


def test_a_moving_camera_leaves_the_level_camera_of_before():
    found = assumed_camera("v", (1080, 1920), SceneCamera(problem="camera moves: frames keep 20, 30 % of ..."))
    assert not found.level_known and np.allclose(found.camera.R, LEVEL_R)
    assert len(found.lines) == 1 and found.lines[0].startswith(FALLBACK) and "camera moves" in found.lines[0]


def test_a_focal_length_the_lines_did_not_measure_is_the_lens_prior_said_once():
    scene = SceneCamera(
        **SCENE, sd={"roll_deg": 0.3, "pitch_deg": 2.0}, source=SOURCES, focal_note=f"{NOT_MEASURED}: too few lines"
    )
    found = assumed_camera("v", (1080, 1920), scene)
    assert found.level_known and found.camera.K[0, 0] == pytest.approx(prior_focal((1080, 1920)))
    assert found.record["focal_px"]["source"] == PRIOR and found.record["focal_px"]["sd"] is None
    assert sum(NOT_MEASURED in line for line in found.lines) == 1
    assert pose_of(found.camera)["pitch_deg"] == pytest.approx(15.0)


def test_the_video_metadata_focal_length_comes_first():
    scene = SceneCamera(
        **SCENE,
        focal_px=1500.0,
        sd={"roll_deg": 0.3, "pitch_deg": 0.3, "focal_px": 30.0},
        source={**SOURCES, "focal_px": FOCAL_SOURCE},
    )
    found = assumed_camera("v", (1080, 1920), scene, metadata_focal=1234.0)
    assert found.camera.K[0, 0] == 1234.0 and found.record["focal_px"]["source"] == METADATA
    assert not any(NOT_MEASURED in line for line in found.lines)


def _recorded(path: Path, entity: str) -> dict:
    """The columns of the static chunk of ``entity`` in the rerun recording at ``path``, read by rerun's own reader."""
    from rerun.chunk import RrdReader

    (chunk,) = [c for c in RrdReader(path).stream() if c.entity_path == entity]
    return chunk.to_record_batch().to_pydict()


def test_the_report_and_the_recording_show_the_estimated_camera(tiny_default_prior, data_dir, tmp_path, run_cli):
    """cam02 lifted without --cams: the report's person picture shows the camera's horizon (read back by OpenCV: a
    straight magenta line in the picture's column) under a caption naming each quantity, and the recording holds the
    estimate as text, the horizon in the camera's image (on the line where the camera sees points at its height)
    and the same horizon in the person's thumbnail (read back by rerun's own reader)."""
    video = data_dir / BALANCING / "cam02.mp4"
    args = ["--persons", "largest", "--samples", FLOOR_PASS_SAMPLES, "--formats", "npz,report,rrd"]
    code, _, stderr = run_cli("lift", video, *args, "--out", tmp_path)
    assert code == 0, stderr
    result = platypose.load_result(tmp_path / "cam02" / "cam02.npz")
    record, camera = result.meta["camera"], result.cameras[0]

    report = cv2.imread(str(tmp_path / "cam02" / "cam02_report.png"))
    ys, xs = np.nonzero(np.all(report == (255, 0, 255), axis=-1))
    assert len(xs) > 40 and xs.max() < 0.15 * report.shape[1]  # in the pictures' column
    fitted = np.polyfit(xs, ys, 1)
    assert np.abs(np.polyval(fitted, xs) - ys).max() < 3.0  # one straight line
    roll = np.degrees(np.arctan(fitted[0]))  # the picture keeps its aspect: the horizon's tilt is the roll's
    assert roll == pytest.approx(record["roll_deg"]["value"], abs=2.0)

    text = _recorded(tmp_path / "cam02" / "cam02.rrd", "/world/cameras/cam02/estimate")["TextDocument:text"][0][0]
    for key in ("roll_deg", "pitch_deg", "focal_px"):
        assert record[key]["source"] in text
    assert f"roll {record['roll_deg']['value']:.1f} +- {record['roll_deg']['sd']:.1f} deg" in text
    strips = _recorded(tmp_path / "cam02" / "cam02.rrd", "/world/cameras/cam02/horizon")["LineStrips2D:strips"]
    ends = np.array(strips[0][0])
    rvec = cv2.Rodrigues(np.asarray(camera.R, np.float64))[0]
    ahead = camera.R[2] * [1.0, 1.0, 0.0]  # the optical axis, levelled
    ahead /= np.linalg.norm(ahead)
    side = np.cross(ahead, [0.0, 0.0, 1.0])
    far = camera.center + 1000.0 * ahead + np.outer([-200.0, 200.0], side)  # ahead, at the camera's height
    seen, _ = cv2.projectPoints(far, rvec, np.asarray(camera.t, np.float64), np.asarray(camera.K), None)
    seen = seen.reshape(-1, 2)
    normal = np.array([seen[1, 1] - seen[0, 1], seen[0, 0] - seen[1, 0]])
    assert np.abs((ends - seen[0]) @ normal / np.linalg.norm(normal)).max() < 2.0
    thumbnail = _recorded(tmp_path / "cam02" / "cam02.rrd", "/who/p0/thumbnail")["Image:buffer"][0][0]
    assert (np.asarray(thumbnail).reshape(-1, 3) == (255, 0, 255)).all(axis=1).sum() > 20


def test_a_video_through_a_wide_lens_is_lifted_on_its_distortion_and_calib_estimate_keeps_it(
    tiny_default_prior, data_dir, tmp_path, run_cli
):
    """cam03 as a barrel lens (the division model's k = -0.4, zoomed 1.67 times to fill the frame) would have filmed
    it: the lift finds the lens (k within 0.03) and the rig's pitch and roll (within 2 degrees), its camera carries
    OpenCV's rational coefficients, the log and the recording's horizon show it bent, and ``calib estimate`` writes
    the 8 coefficients, read back as they were."""
    from platypose.lifting.calibration.scene.distortion import bent_image
    from platypose.media import iter_timed_frames, video_info

    video = tmp_path / "wide.mp4"
    info = video_info(data_dir / BALANCING / "cam03.mp4")
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), info.fps, info.image_size[::-1])
    for _, _, frame in iter_timed_frames(data_dir / BALANCING / "cam03.mp4", max_frames=40):
        writer.write(bent_image(frame, -0.4)[0])
    writer.release()
    truth = pose_of(load_calibration(data_dir / BALANCING / "calib_pose2sim.toml").camera("cam_03"))
    code, _, stderr = run_cli(
        "lift", video, "--persons", "largest", "--samples", 4, "--formats", "npz,rrd", "--out", tmp_path
    )
    assert code == 0, stderr
    result = platypose.load_result(tmp_path / "wide" / "wide.npz")
    lens = result.meta["camera"]["distortion"]
    assert lens["value"] == pytest.approx(-0.4, abs=0.03)
    used = pose_of(result.cameras[0])
    assert abs(used["pitch_deg"] - truth["pitch_deg"]) < 2.0 and abs(used["roll_deg"] - truth["roll_deg"]) < 2.0
    assert np.allclose(result.cameras[0].dist, lens["opencv"]) and np.any(result.cameras[0].dist[5:] != 0)
    assert sum("lens distortion k = -0.4" in note for note in result.meta["notes"]) == 1
    strip = np.array(
        _recorded(tmp_path / "wide" / "wide.rrd", "/world/cameras/wide/horizon")["LineStrips2D:strips"][0][0]
    )
    chord = strip[-1] - strip[0]
    bow = np.abs(chord[0] * (strip[:, 1] - strip[0, 1]) - chord[1] * (strip[:, 0] - strip[0, 0])) / np.linalg.norm(
        chord
    )
    assert len(strip) > 10 and bow.max() > 10.0  # a curve, not a line
    out = tmp_path / "wide.toml"
    code, _, stderr = run_cli("calib", "estimate", video, "--persons", "largest", "--out", out)
    assert code == 0, stderr
    assert np.allclose(load_calibration(out).cameras[0].dist, result.cameras[0].dist, rtol=1e-6, atol=1e-9)


@pytest.mark.slow
def test_the_sports2d_walker_crosses_her_lawn_on_its_floor_without_calibration(data_dir):
    """The Sports2D demo lifted on its scene's camera, the shipped prior: the walker's lowest ankle, median per whole
    second of the take, varies by at most 8 cm along her 5.5 m path (issue 48). Her image grows as she crosses while
    her feet stay on one image row; with one floor reading per window her feet rose 6-16 cm (10.3 cm apart)."""
    result = platypose.lift(data_dir / "video/sports2d-demo/demo.mp4", samples=20)
    ankles = np.asarray(result.median)[..., [3, 6], 2]  # (P, T, 2) above the floor
    lowest = np.where(np.isfinite(ankles).all(-1), np.nan_to_num(ankles).min(-1), np.nan)  # NaN where absent
    walker = int(np.argmin(np.nanmedian(lowest, axis=1)))  # the man stands on a roof
    present = np.isfinite(lowest[walker])
    times = np.asarray(result.frame_times)[present]
    second = np.floor(times - result.frame_times[0]).astype(int)
    per_second = [np.median(lowest[walker, present][second == s]) for s in np.unique(second)]
    assert len(per_second) >= 5 and np.ptp(per_second) <= 0.08, per_second
