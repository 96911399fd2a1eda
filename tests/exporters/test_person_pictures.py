"""Who is who: a person's good frame, image box and thumbnail from the real Pose2Sim video, in the recording."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from export_helpers import read_entities, two_person_result

from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.exporters.person_pictures import THUMBNAIL_HEIGHT, GoodFrame, good_frame, good_frames, thumbnails
from platypose.exporters.rrd import write_rrd
from platypose.lifting.calibration.defaults import default_camera

TAKE = "video/pose2sim-balancing"


def test_the_good_frame_of_each_real_person_boxes_their_joints_and_its_thumbnail_is_cut_from_the_video(data_dir):
    tracks = read_openpose_folder(data_dir / TAKE / "openpose-body25b" / "cam01_json")
    size = tracks.image_size
    camera = default_camera("cam01", *size)
    frames = {}
    for p in range(tracks.num_persons):
        kp = tracks.keypoints[:, p][None]  # (1, T, 17, 3)
        good = good_frame(kp, [size])
        frames[p] = good
        seen = kp[0, good.frame, :, 2] > 0
        counts = (kp[0, :, :, 2] > 0).sum(axis=-1)
        need = min(15, counts.max())  # most joints seen, or 15
        x1, y1, x2, y2 = good.box
        assert seen.sum() >= need and x1 < x2 and y1 < y2
        joints = kp[0, good.frame, seen, :2]
        assert (joints >= [x1, y1]).all() and (joints <= [x2, y2]).all()  # the box holds the joints, widened
        taller = counts >= need
        heights = [np.ptp(kp[0, t, kp[0, t, :, 2] > 0, 1]) for t in np.flatnonzero(taller)]
        assert np.isclose(np.ptp(joints[:, 1]), max(heights))  # the tallest of the well-seen frames
    result = SimpleNamespace(cameras=(camera,), fps=60.0, frame_times=tracks.frame_times)
    pictures = thumbnails(result, {"cam01": data_dir / TAKE / "cam01.mp4"}, frames)
    assert set(pictures) == set(frames)
    for p, picture in pictures.items():
        x1, y1, x2, y2 = frames[p].box
        assert picture.shape[0] == THUMBNAIL_HEIGHT and picture.dtype == np.uint8
        assert abs(picture.shape[1] / THUMBNAIL_HEIGHT - (x2 - x1) / (y2 - y1)) < 0.05
        assert picture.std() > 10  # a picture of someone, not a blank
    assert thumbnails(result, {}, frames) == {}  # no video: no thumbnail


def test_each_real_person_of_a_result_gets_a_picture_of_themselves(data_dir):
    tracks = read_openpose_folder(data_dir / TAKE / "openpose-body25b" / "cam01_json")  # two people
    keypoints = np.moveaxis(tracks.keypoints, 1, 0)[None]  # (C, P, T, 17, 3), as in a LiftResult
    camera = default_camera("cam01", *tracks.image_size)
    result = SimpleNamespace(cameras=(camera,), fps=60.0, frame_times=tracks.frame_times, keypoints2d=keypoints)
    result.num_persons = tracks.num_persons
    frames = good_frames(result)
    assert sorted(frames) == [0, 1]
    for p, good in frames.items():
        x1, y1, x2, y2 = good.box
        own = keypoints[good.camera, p, good.frame]
        joints = own[own[:, 2] > 0, :2]
        assert len(joints) >= 4 and ((joints >= [x1, y1]) & (joints <= [x2, y2])).all()  # their own joints
    pictures = thumbnails(result, {"cam01": data_dir / TAKE / "cam01.mp4"}, frames)
    assert frames[0].box != frames[1].box and pictures[0].shape != pictures[1].shape  # two different pictures


def test_the_recording_holds_who_each_person_is(data_dir, tmp_path):
    result = two_person_result(data_dir)
    frames = {1: GoodFrame(0, 12, (100.0, 50.0, 300.0, 450.0))}
    picture = np.full((THUMBNAIL_HEIGHT, 80, 3), 200, np.uint8)
    path = write_rrd(result, tmp_path / "who.rrd", "who", who=(frames, {1: picture}))
    entities = read_entities(path)
    text = entities["/who/p7"]["static:TextDocument:text"][0][0]
    assert text == f"p7: best seen by {result.cameras[0].name} in frame 12, image box 100,50-300,450 px"
    assert "/who/p7/thumbnail" in entities and "/who/p0" not in entities
