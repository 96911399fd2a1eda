"""Video frames read in a process forked from one that read video (the recording's watched writer,
platypose.exporters.watched_writer): PyAV 18.1.1 keeps its frame converter per process with FFmpeg's slice threads,
which a forked child does not have, and the child waited for them forever (``platypose demo`` hung in CI)."""

from __future__ import annotations

import multiprocessing
from pathlib import Path

import av
import numpy as np
import pytest

from platypose.media import iter_timed_frames, upright

DEMO = "video/sports2d-demo/demo.mp4"


def _read_three(path: str, conn) -> None:
    """In the child: read three frames, send their shape back."""
    images = [image for _, _, image in iter_timed_frames(path, max_frames=3)]
    conn.send(images[-1].shape)
    conn.close()


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="no fork on this platform")
def test_a_forked_process_reads_video_after_its_parent_did(data_dir: Path):
    """The parent reads frames (with PyAV's own conversion too), then a forked child reads the same video within
    20 s; the frames equal PyAV's own conversion."""
    path = str(data_dir / DEMO)
    with av.open(path) as container:
        for index, frame in enumerate(container.decode(video=0)):
            np.testing.assert_array_equal(upright(frame, "rgb24"), frame.to_ndarray(format="rgb24"))
            if index == 2:
                break
    parent_images = [image for _, _, image in iter_timed_frames(path, max_frames=3)]
    receive, send = multiprocessing.Pipe(duplex=False)
    child = multiprocessing.get_context("fork").Process(target=_read_three, args=(path, send), daemon=True)
    child.start()
    send.close()
    try:
        assert receive.poll(20.0), "the forked child did not read three frames in 20 s"
        assert receive.recv() == parent_images[-1].shape
    finally:
        if child.is_alive():
            child.kill()
        child.join()
