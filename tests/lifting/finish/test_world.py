"""The estimated world: a one-camera lift's outputs stand on its estimated floor, z up, and look the same."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from platypose.lifting.calibration.defaults import default_camera
from platypose.lifting.camera import project
from platypose.lifting.finish.world import floor_world, level_on_floor, move_frames
from platypose.lifting.floor import Floor


def tilted_floor(pitch_deg: float, height: float) -> Floor:
    """The floor a level default camera (looking along +y, z up) sees when it is really pitched down by
    ``pitch_deg`` at ``height`` above it."""
    pitch = np.radians(pitch_deg)
    normal = np.array([0.0, -np.sin(pitch), np.cos(pitch)])
    return Floor(tuple(normal), height, "estimated")  # the camera centre (origin) is ``height`` above it


def test_the_floor_becomes_z_0_and_the_camera_stands_at_its_height_seeing_the_same_image():
    camera = default_camera("cam", 1080, 1920)
    floor = tilted_floor(20.0, 3.0)
    rng = np.random.default_rng(0)
    points = rng.normal([0.0, 6.0, -1.0], 1.0, (5, 7, 17, 3))  # (N, T, 17, 3)
    move = floor_world(floor, camera)
    moved, seen = move.points(points), move.camera(camera)
    assert np.allclose(moved[..., 2], floor.height(points))  # heights above the floor are z
    assert np.allclose(seen.center, [0.0, 0.0, 3.0])
    assert np.allclose(project(points, camera), project(moved, seen), atol=1e-6)
    assert np.degrees(np.arcsin(seen.R[2] @ [0.0, 0.0, -1.0])) > 19.99  # pitched 20 degrees down, looking along +y
    assert seen.R[2][1] > 0 and abs(seen.R[2][0]) < 1e-9


def test_outputs_are_moved_in_place_chunk_by_chunk_and_the_meta_says_so():
    camera = default_camera("cam", 1080, 1920)
    floor = tilted_floor(10.0, 2.0)
    hypotheses = np.random.default_rng(1).normal(0.0, 1.0, (2, 3, 9, 17, 3)).astype(np.float32)
    median = hypotheses[:, 0].copy()
    expected = floor.height(hypotheses.astype(np.float64))
    found = {"camera_height_m": 2.0, "camera_pitch_deg": 10.0, "stance_points": 40}
    seen, said = level_on_floor(replace(floor, found=found), camera, (hypotheses, median))
    assert np.allclose(hypotheses[..., 2], expected, atol=1e-5) and np.allclose(median, hypotheses[:, 0])
    assert said["normal"] == [0.0, 0.0, 1.0] and said["offset_m"] == 0.0 and said["source"] == "estimated"
    assert said["camera_height_m"] == 2.0 and said["frame"].startswith("estimated world: z = 0 is the estimated floor")
    chunked = np.random.default_rng(2).normal(0.0, 1.0, (4, 5, 17, 3))
    whole = floor_world(floor, camera).points(chunked)
    move_frames(chunked, floor_world(floor, camera), chunk=2)
    assert np.allclose(chunked, whole)


def test_info_says_the_world_and_heights_above_its_floor(run_cli, data_dir, tmp_path):
    from export_helpers import two_person_result

    from platypose.exporters.npz import write_npz

    floor = {"normal": [0.0, 0.0, 1.0], "offset_m": 0.0, "source": "estimated", "frame": "estimated world: z = 0 ..."}
    path = write_npz(two_person_result(data_dir).with_meta(floor=floor), tmp_path / "take.npz")
    code, out, err = run_cli("info", path)
    assert code == 0, err
    assert "  world: estimated world: z = 0 ..." in out and out.count("m above the floor (z = 0),") == 2
