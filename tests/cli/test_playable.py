"""The recording's video re-encoded beside the lift (platypose_cli/runs/playable.py): the same H.264 file the export
would make, started before detection, stopped when the job ends early, and a video it cannot read left to the
export as before."""

from __future__ import annotations

import threading

import av
import numpy as np
import pytest
from export_helpers import read_entities

from platypose.cli.runs.playable import PlayableCopies
from platypose.exporters.video import reencode_h264

DEMO = "video/sports2d-demo/demo.mp4"  # VP9: rerun cannot play it, the recording needs an H.264 copy


def test_a_vp9_video_is_copied_to_the_h264_file_the_export_makes(data_dir, tmp_path):
    video = data_dir / DEMO
    with PlayableCopies([video, None], tmp_path) as copies:
        assert copies.reencoding == [video]
        paths = copies.paths()
    assert paths[1] is None and paths[0] == tmp_path / ".playable-0.mp4"
    reencode_h264(video, tmp_path / "export.mp4")
    assert paths[0].read_bytes() == (tmp_path / "export.mp4").read_bytes()  # the export's own re-encoding
    with av.open(str(paths[0])) as container:
        assert container.streams.video[0].codec_context.name == "h264"


def test_a_playable_or_unreadable_video_gets_no_copy_and_a_stopped_one_none(data_dir, tmp_path):
    h264 = tmp_path / "h264.mp4"
    reencode_h264(data_dir / DEMO, h264)
    broken = tmp_path / "broken.mp4"
    broken.write_bytes(b"not a video")
    with PlayableCopies([h264, broken], tmp_path) as copies:
        assert copies.reencoding == [] and copies.paths() == [None, None]
    stop = threading.Event()
    stop.set()
    assert reencode_h264(data_dir / DEMO, tmp_path / "stopped.mp4", stop=stop) is False
    copies = PlayableCopies([data_dir / DEMO], tmp_path / "gone")  # its folder missing: the copy fails
    assert copies.paths() == [None]


@pytest.mark.slow
def test_lift_embeds_the_copy_made_beside_the_lift(run_cli, data_dir, prior_file, tmp_path):
    """``lift --formats rrd`` of the VP9 demo: the re-encoding starts with the job and the recording embeds its H.264
    copy, frame for frame the video's."""
    code, out, err = run_cli(
        "lift", data_dir / DEMO, "--prior", prior_file, "--samples", "2", "--formats", "npz,rrd", "--out", tmp_path
    )
    assert code == 0, err
    log = (tmp_path / "demo/log.txt").read_text()
    assert "re-encoding demo.mp4 to H.264 for rerun, beside the lift" in log.splitlines()[1]
    assert "camera(s) demo: video re-encoded for rerun beside the lift in" in log
    assert "re-encoding demo.mp4 to H.264 for rerun\n" not in log  # not again at export
    video = read_entities(tmp_path / "demo/demo.rrd")["/world/cameras/demo/video"]
    (tmp_path / "embedded.mp4").write_bytes(video["static:AssetVideo:blob"][0])
    reencode_h264(data_dir / DEMO, tmp_path / "export.mp4")
    assert (tmp_path / "embedded.mp4").read_bytes() == (tmp_path / "export.mp4").read_bytes()
    assert len(video["VideoFrameReference:timestamp"]) == 230
    assert not list((tmp_path).glob(".demo.*.partial"))
    assert np.isfinite(np.load(tmp_path / "demo/demo.npz")["median"]).any()
