"""A job's videos made playable for its recording beside the lift: the H.264 re-encoding that ``--formats rrd``
needs for a video rerun cannot play (VP9, HEVC, a rotated phone video) runs in a background thread from the job's
start, while the other core detects and lifts, instead of after them (issue 50: 46 of the 60 s clip's 401 s).

It is only a head start: a video that cannot be probed or re-encoded here is left to the export, which re-encodes
it (or fails with its usual one-line error) as it would without this."""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from pathlib import Path

from platypose.exporters.video import needs_reencode, reencode_h264


class PlayableCopies:
    """Each of ``videos`` (None: a view without one) as a file rerun plays: its H.264 copy written into ``folder`` by
    a background thread started here, where it needs one (:meth:`paths` waits for it; :meth:`close` stops it)."""

    def __init__(self, videos: Sequence[Path | None], folder: Path) -> None:
        self.videos = list(videos)
        self.copies = [
            None if v is None or not _needs_copy(v) else folder / f".playable-{i}.mp4" for i, v in enumerate(videos)
        ]
        self.done = [False] * len(self.videos)
        self.stop = threading.Event()
        self.seconds = 0.0
        self.thread = threading.Thread(target=self._encode, name="platypose-reencode", daemon=True)
        if self.reencoding:
            self.thread.start()

    @property
    def reencoding(self) -> list[Path]:
        """The videos re-encoded here."""
        return [v for v, c in zip(self.videos, self.copies) if c is not None]

    def _encode(self) -> None:
        began = time.perf_counter()
        for i, (video, copy) in enumerate(zip(self.videos, self.copies)):
            if copy is None:
                continue
            try:
                self.done[i] = reencode_h264(video, copy, stop=self.stop)
            except Exception:  # left to the export, which says what is wrong as it always did
                self.done[i] = False
            if self.stop.is_set():
                return
        self.seconds = time.perf_counter() - began

    def paths(self) -> list[Path | None]:
        """Each video's playable copy, once written; None for a video that has none (the export then takes the
        video itself, re-encoding it there if needed)."""
        if self.thread.ident is not None:
            self.thread.join()
        return [c if ok else None for c, ok in zip(self.copies, self.done)]

    def close(self) -> None:
        """Stop an unfinished re-encoding and wait for its thread."""
        self.stop.set()
        if self.thread.ident is not None:
            self.thread.join()

    def __enter__(self) -> PlayableCopies:
        return self

    def __exit__(self, *failure) -> None:
        self.close()


def _needs_copy(video: Path) -> bool:
    """Whether ``video`` needs a playable copy; False where it cannot even be probed (the lift says why)."""
    try:
        return needs_reencode(video)
    except Exception:
        return False
