"""The report picture and the person pictures: long flag text does not run into the row's title,
a report without a video says why its thumbnails are missing, and two overlapping people do not share a picture.
The audit case (marker ``audit``, run with ``pytest -m audit``) exports a real lift's recording with its video and
checks that each person's picture boxes their own joints (:mod:`audit_support`)."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from audit_support import TAKE, Case, Run, check_case, lift_args, openpose_copy, platypose, registry
from export_helpers import read_entities, two_person_result
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from platypose.exporters import export
from platypose.exporters.npz import read_npz
from platypose.exporters.person_pictures import good_frames
from platypose.lifting.calibration.defaults import default_camera

LONG_FLAGS = (
    "spread (hypotheses 2.3 m apart (over 1 m)), sliding (feet slide 0.84 m/s while standing (over 0.3 m/s)), "
    "depth (the pelvis jumps 1.2 m in 0.1 s), height (1.31 m tall, outside 1.45-2.10 m), behind (the camera)"
)


@pytest.fixture
def drawn(monkeypatch) -> list:
    """Figures the report saves, kept for the test to measure."""
    figures = []
    save = Figure.savefig

    def keep(self, *args, **kwargs):
        figures.append(self)
        return save(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    return figures


def _titles(figure) -> list:
    FigureCanvasAgg(figure).draw()
    renderer = figure.canvas.get_renderer()
    texts = [t for ax in figure.axes for t in (ax.title, ax._left_title, ax._right_title) if t.get_text()]
    return [(t.get_text(), t.get_window_extent(renderer)) for t in texts]


def test_long_flag_text_does_not_run_into_the_rows_title(data_dir, tmp_path, drawn) -> None:
    result = two_person_result(data_dir)
    flags = [{"flags": ["spread", "sliding"], "flag_text": LONG_FLAGS}] * result.num_persons
    said = []
    export(result.with_meta(plausibility=flags), tmp_path, "r", "report", say=said.append)
    titles = _titles(drawn[0])
    overlaps = [
        (a[:40], b[:40]) for i, (a, box) in enumerate(titles) for b, other in titles[i + 1 :] if box.overlaps(other)
    ]
    assert overlaps == []
    first = [text for text, _ in titles if text.startswith("person 0: hips and knees")]
    assert first and "flagged: spread (hypotheses 2.3 m apart" in first[0]


def test_a_report_without_videos_says_why_it_has_no_thumbnails(data_dir, tmp_path, drawn) -> None:
    result = two_person_result(data_dir)
    said = []
    export(result, tmp_path, "r", "report", say=said.append)
    cameras = ", ".join(sorted({result.cameras[f.camera].name for f in good_frames(result).values()}))
    assert f"r: no person thumbnails from camera(s) {cameras}: no video of them (--video CAMERA=PATH)" in said
    captions = [(text, box) for text, box in _titles(drawn[0]) if text.startswith("person 7\n")]
    (text, box), width = captions[0], drawn[0].bbox.width
    assert re.search(r"\(no thumbnail: no video of cam0\d given\)$", " ".join(text.split()))
    assert box.x0 >= 0 and box.x1 <= width  # the whole caption is in the picture, none cut at its edge


def _person(x: float, height: float) -> np.ndarray:
    """17 joints of a standing figure ``height`` px tall with its left edge at ``x`` (x, y, confidence)."""
    joints = np.zeros((17, 3))
    joints[:, 0] = x + np.linspace(0, height / 3, 17)
    joints[:, 1] = 100 + np.linspace(0, height, 17)
    joints[:, 2] = 1.0
    return joints


def test_two_overlapping_people_get_pictures_of_their_own(tmp_path) -> None:
    keypoints = np.zeros((1, 2, 20, 17, 3))  # (C, P, T, 17, 3), as in a LiftResult
    for t in range(10):  # together, nearest the camera: each tallest here, one box over the other
        keypoints[0, 0, t] = _person(500, 400 + t)
        keypoints[0, 1, t] = _person(520, 400 + t)
    for t in range(10, 20):  # apart, farther away
        keypoints[0, 0, t] = _person(100, 300)
        keypoints[0, 1, t] = _person(1200, 300)
    result = SimpleNamespace(cameras=(default_camera("cam01", 1080, 1920),), keypoints2d=keypoints, num_persons=2)
    frames = good_frames(result)
    boxes = [np.array(frames[p].box) for p in (0, 1)]
    overlap = np.clip(np.minimum(boxes[0][2:], boxes[1][2:]) - np.maximum(boxes[0][:2], boxes[1][:2]), 0, None)
    assert overlap.prod() == 0.0  # the pictures do not show the same people
    assert frames[0].frame >= 10 and frames[1].frame >= 10
    assert frames[0].box[2] < 500 < frames[1].box[0]  # each picture shows its own person (at 100 and 1200 px)


CASES: list[Case] = []
case = registry(CASES)


WHO = re.compile(r"p(\d+): best seen by (\S+) in frame (\d+), image box (\d+),(\d+)-(\d+),(\d+) px")


def _own_pictures(npz: Path, recording: Path) -> str | None:
    """None when every person's picture in ``recording`` (its who/ texts) boxes their own joints in ``npz``, and no
    two people share a box; else what is wrong."""
    result = read_npz(npz)
    texts = [
        v["static:TextDocument:text"][0][0]
        for k, v in read_entities(recording).items()
        if re.fullmatch(r"/who/p\d+", k)
    ]
    boxes = {}
    for text in texts:
        track, camera, frame, *box = WHO.fullmatch(text).groups()
        c = [cam.name for cam in result.cameras].index(camera)
        joints = result.keypoints2d[c, list(result.track_ids).index(int(track)), int(frame)]
        joints = joints[joints[:, 2] > 0, :2]
        x1, y1, x2, y2 = map(float, box)
        if not ((joints >= [x1 - 1, y1 - 1]) & (joints <= [x2 + 1, y2 + 1])).all():
            return f"p{track}'s picture does not show p{track}: {text}"
        boxes[track] = tuple(box)
    if len(boxes) < 2 or len(set(boxes.values())) < len(boxes):
        return f"the people do not have pictures of their own: {texts}"
    return None


@case("every-person-gets-their-own-picture")
def _(w: Path) -> Run:
    done = platypose(lift_args(openpose_copy(w / "kp"), w / "res", "--formats", "npz"), 240)
    assert done is not None and done.returncode == 0, done and done.stderr
    npz = w / "res/cam01/cam01.npz"
    args = ["export", npz, "--formats", "rrd", "--out", w / "out", "--video", f"cam_01={TAKE / 'cam01.mp4'}"]
    return Run(args, "ok", lambda proc: _own_pictures(npz, w / "out/cam01.rrd"), timeout=240)


@pytest.mark.audit
@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
