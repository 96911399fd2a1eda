"""rerun recordings read back with rerun's own reader (``rerun.chunk.RrdReader``) on real motion and video."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import av
import numpy as np
import pytest
from export_helpers import read_entities, two_person_result

from platypose.exporters.rrd import camera_grid_columns, person_colour, quality_flags, quality_text, write_rrd
from platypose.exporters.video_clock import video_stamps
from platypose.lifting.errors import InputError
from platypose.lifting.skeleton import BONES, NUM_JOINTS

CAM01 = "video/pose2sim-balancing/cam01.mp4"


@pytest.fixture(scope="module")
def result(data_dir):
    return two_person_result(data_dir)


@pytest.fixture(scope="module")
def recording(result, data_dir, tmp_path_factory):
    path = tmp_path_factory.mktemp("rrd") / "clip.rrd"
    write_rrd(result, path, "clip", {"cam01": data_dir / CAM01})
    return path


def test_people_positions_equal_the_npz(result, recording):
    entities = read_entities(recording)
    N = result.num_hypotheses
    for p, track in enumerate(result.track_ids):
        on = result.present()[p]
        hyp = entities[f"/world/people/p{track}/hypotheses"]
        assert len(hyp["Points3D:positions"]) == on.sum()  # absent frames are not logged
        assert hyp["frame"] == np.flatnonzero(on).tolist()
        np.testing.assert_allclose(np.array(hyp["time"]) / 1e9, result.frame_times[on], atol=1e-9)
        got = np.array(hyp["Points3D:positions"], dtype=np.float32)  # (T_on, N * 17, 3)
        want = np.moveaxis(result.hypotheses[p][:, on], 0, 1).reshape(-1, N * NUM_JOINTS, 3)
        np.testing.assert_array_equal(got, want)
        assert hyp["static:Points3D:class_ids"][0] == np.repeat(np.arange(N), NUM_JOINTS).tolist()
        assert hyp["static:Points3D:keypoint_ids"][0] == np.tile(np.arange(NUM_JOINTS), N).tolist()
        median = entities[f"/world/people/p{track}/median"]
        np.testing.assert_array_equal(np.array(median["Points3D:positions"], dtype=np.float32), result.median[p][on])
        assert set(median["static:Points3D:class_ids"][0]) == {N}  # the class after the hypotheses
        bones = np.array(entities[f"/world/people/p{track}/median/bones"]["LineStrips3D:strips"], dtype=np.float32)
        assert bones.shape == (on.sum(), len(BONES), 2, 3)
        np.testing.assert_array_equal(bones[:, :, 0], result.median[p][on][:, [c for c, _ in BONES]])
        np.testing.assert_array_equal(bones[:, :, 1], result.median[p][on][:, [q for _, q in BONES]])
        spread = entities[f"/world/people/p{track}/spread"]
        radii = np.array(spread["Ellipsoids3D:half_sizes"], dtype=np.float64)[..., 0]
        expected = np.sqrt(((result.hypotheses[p][:, on] - result.median[p][on]) ** 2).sum(-1).mean(0))
        np.testing.assert_allclose(radii, expected, rtol=1e-5)
        centres = np.array(spread["Ellipsoids3D:centers"], dtype=np.float32)
        np.testing.assert_array_equal(centres, result.median[p][on])
        energy = np.array(entities[f"/plots/energy/p{track}"]["Scalars:scalars"])
        np.testing.assert_allclose(energy[:, 1], np.median(result.energy[p][:, on], axis=0), rtol=1e-5)


def test_each_person_has_its_colour_and_label(result, recording):
    entities = read_entities(recording)
    medians = []
    for p, track in enumerate(result.track_ids):
        context = entities[f"/world/people/p{track}"]["static:AnnotationContext:context"][0][0]
        classes = {c["class_id"]: c["class_description"]["info"] for c in context}
        assert classes[result.num_hypotheses]["label"] == f"p{track} median"
        medians.append(classes[result.num_hypotheses]["color"])
        label = entities[f"/world/people/p{track}/label"]
        assert all(row[0].startswith(f"p{track}") for row in label["Points3D:labels"])
        head = result.median[p][result.present()[p]][:, 10]
        np.testing.assert_allclose(np.array(label["Points3D:positions"])[:, 0, 2], head[:, 2] + 0.25, atol=1e-6)
        kp = entities[f"/world/cameras/cam01/keypoints/p{track}"]["static:AnnotationContext:context"][0][0]
        assert kp[0]["class_description"]["info"]["color"] == medians[-1]
    assert len(set(medians)) == len(medians)  # one colour per person
    assert medians[0] == int.from_bytes(bytes(person_colour(0)), "big")
    quality = entities["/quality"]["static:TextDocument:text"][0][0]
    assert "p0" in quality and "p7" in quality


def test_video_frames_share_the_skeletons_stamps_and_frames(result, data_dir, tmp_path):
    """Video frames at the output frames' times carry exactly their stamps and indices, on both timelines."""
    import dataclasses

    with av.open(str(data_dir / CAM01)) as container:
        stream = container.streams.video[0]
        video_times = np.array([float(f.pts * stream.time_base) for f in container.decode(stream)])
    T = result.num_frames
    clip = dataclasses.replace(result, frame_times=video_times[10 : 10 + T], fps=60.0)
    path = write_rrd(clip, tmp_path / "sync.rrd", "sync", {"cam01": data_dir / CAM01})
    entities = read_entities(path)
    video = entities["/world/cameras/cam01/video"]
    skeleton = entities["/world/people/p0/median"]
    on_frames = [(f, t) for f, t in zip(video["frame"], video["time"]) if f is not None]
    assert [f for f, _ in on_frames] == list(range(T))
    assert [t for _, t in on_frames] == skeleton["time"]  # exactly the same nanoseconds
    assert len(video["VideoFrameReference:timestamp"]) == 100  # frames outside the output frames: time only
    stamps, frames = video_stamps(np.array([0.0, 0.0049, 0.0101, 0.011, 1.0]), np.array([0.0, 0.01]), 100.0)
    assert frames.tolist() == [0, -1, 1, -1, -1]  # the nearest of two close video frames, none beyond half a frame
    assert stamps.tolist() == [0, 4_900_000, 10_000_000, 11_000_000, 1_000_000_000]


def test_camera_grid_gives_the_largest_views():
    assert camera_grid_columns([(1080, 1920)]) == 1
    assert camera_grid_columns([(1080, 1920)] * 4) == 2
    assert camera_grid_columns([(1920, 1080)] * 4) == 4  # portrait views side by side
    assert camera_grid_columns([(1080, 1920)] * 2) == 1  # landscape views stacked


def test_cameras_keypoints_and_video(result, recording, data_dir):
    entities = read_entities(recording)
    cam = entities["/world/cameras/cam01"]
    K = np.array(cam["static:Pinhole:image_from_camera"][0]).reshape(3, 3).T  # stored column-major
    np.testing.assert_allclose(K, result.cameras[0].K)
    np.testing.assert_allclose(cam["static:Transform3D:translation"][0][0], result.cameras[0].t, atol=1e-6)
    assert cam["static:Pinhole:resolution"][0] == [[1080, 1920]]  # width, height
    kp = entities["/world/cameras/cam02/keypoints/p7"]
    counts = [len(row) for row in kp["Points2D:positions"]]
    assert counts == [0] * 5 + [NUM_JOINTS] * 25  # person 7 absent (confidence 0) in the first 5 frames
    np.testing.assert_allclose(kp["Points2D:positions"][10], result.keypoints2d[1, 1, 10, :, :2], rtol=1e-6)
    video = entities["/world/cameras/cam01/video"]
    assert video["static:AssetVideo:blob"][0] == (data_dir / CAM01).read_bytes()  # H.264: embedded as is
    assert len(video["VideoFrameReference:timestamp"]) == 100
    assert "/world/cameras/cam02/video" not in entities  # no video given for cam02


def test_default_blueprint_has_3d_camera_and_per_person_plot_views(recording):
    blueprint = read_entities(recording, "blueprint")
    views = {
        (cols["ViewBlueprint:class_identifier"][0][0], cols["ViewBlueprint:space_origin"][0][0])
        for path, cols in blueprint.items()
        if "ViewBlueprint:class_identifier" in cols
    }
    assert views == {
        ("3D", "world"),
        ("2D", "world/cameras/cam01"),
        ("2D", "world/cameras/cam02"),
        ("TimeSeries", "plots/spread/p0"),
        ("TimeSeries", "plots/spread/p7"),
        ("TimeSeries", "plots/energy/p0"),
        ("TimeSeries", "plots/energy/p7"),
        ("TextDocument", "quality"),
    }
    panel = next(cols for path, cols in blueprint.items() if path.endswith("time_panel"))
    assert panel["TimePanelBlueprint:fps"] == [[pytest.approx(120.0)]]  # the frame timeline plays at the data's rate
    assert panel["TimePanelBlueprint:timeline"] == [["time"]]
    assert panel["static:TimePanelBlueprint:play_state"] == [[1]]  # paused


def test_rerun_verifies_the_file(recording):
    rerun_cli = Path(sys.executable).parent / "rerun"
    done = subprocess.run([str(rerun_cli), "rrd", "verify", str(recording)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "1 file verified without error" in done.stderr + done.stdout


def test_vp9_video_is_reencoded_to_h264(result, data_dir, tmp_path):
    from dataclasses import replace

    demo = replace(result, cameras=(replace(result.cameras[0], size=(994, 1768)), *result.cameras[1:]))  # the video's
    path = write_rrd(demo, tmp_path / "demo.rrd", "demo", {"cam01": data_dir / "video/sports2d-demo/demo.mp4"})
    video = read_entities(path)["/world/cameras/cam01/video"]
    (tmp_path / "embedded.mp4").write_bytes(video["static:AssetVideo:blob"][0])
    with av.open(str(tmp_path / "embedded.mp4")) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264" and (stream.width, stream.height) == (1768, 994)
    assert len(video["VideoFrameReference:timestamp"]) == 230
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.rrd", "embedded.mp4"]


def test_video_as_jpeg_frames(result, data_dir, tmp_path):
    path = write_rrd(result, tmp_path / "frames.rrd", "frames", {"cam01": data_dir / CAM01}, video_mode="frames")
    video = read_entities(path)["/world/cameras/cam01/video"]
    assert len(video["EncodedImage:blob"]) == 100 and video["EncodedImage:media_type"] == [["image/jpeg"]] * 100
    np.testing.assert_allclose(np.array(video["time"][:3]) / 1e9, [0, 1 / 60, 2 / 60], atol=1e-6)
    assert video["EncodedImage:blob"][0][:2] == b"\xff\xd8"


def test_failed_export_leaves_no_file(result, data_dir, tmp_path):
    with pytest.raises(InputError, match="no camera named 'cam09'"):
        write_rrd(result, tmp_path / "a.rrd", "a", {"cam09": data_dir / CAM01})
    not_video = data_dir / "PROVENANCE.md"
    with pytest.raises(InputError, match="PROVENANCE.md: cannot read video"):
        write_rrd(result, tmp_path / "b.rrd", "b", {"cam01": not_video})
    assert list(tmp_path.iterdir()) == []


def test_quality_text_says_the_lifts_flags_in_its_words_and_the_warnings(result):
    """Only what the lift flagged is flagged (a stretch the BVH absorbed is a figure, not a flag), in its words."""
    fit = {"median": {"mean_m": 0.01, "max_m": 0.05, "stretch_m": 0.2}}
    said = "under floor (20% of hypothesis-frames more than 3 cm under it)"
    reports = [{"flags": []}, {"flags": ["under floor"], "flag_text": said, "track_id": 7}]  # one per person
    r = result.with_meta(plausibility=reports, warnings=["a warning"], bvh_fit_error={"p7": fit})
    flags = {p: quality_flags(r, p) for p in range(r.num_persons)}
    assert flags == {0: [], 1: [said]}
    text = quality_text(r, flags)
    assert f"flagged: {said}" in text and text.count("flagged") == 1
    assert "- a warning" in text and "BVH fit 10 mm mean / 50 mm max" in text


def test_floor_and_plausibility_from_meta_are_in_the_recording(result, tmp_path):
    floor = {"normal": [0.0, 0.0, 1.0], "offset_m": 0.0, "source": "calibration"}
    reports = [{"flags": []}, {"flags": ["sliding"], "track_id": 7}]
    path = write_rrd(result.with_meta(floor=floor, plausibility=reports), tmp_path / "floor.rrd", "floor")
    entities = read_entities(path)
    strips = entities["/world/floor"]["static:LineStrips3D:strips"][0]
    assert np.allclose([p[2] for strip in strips for p in strip], 0.0)
    assert "sliding" in entities["/world/people/p7/plausibility"]["static:TextDocument:text"][0][0]
    assert "p7 (flagged: sliding)" in str(entities["/world/people/p7/label"])
