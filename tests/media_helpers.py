"""Real videos damaged on purpose, for the tests of what reads them."""

from __future__ import annotations

from pathlib import Path

import av


def truncated_copy(source: Path, target: Path, keep: float) -> Path:
    """``source`` re-muxed with its index first (faststart), then cut to ``keep`` of its bytes."""
    with av.open(str(source)) as inp, av.open(str(target), "w", options={"movflags": "faststart"}) as out:
        stream = out.add_stream_from_template(inp.streams.video[0])
        for packet in inp.demux(inp.streams.video[0]):
            if packet.dts is not None:
                packet.stream = stream
                out.mux(packet)
    data = target.read_bytes()
    target.write_bytes(data[: int(len(data) * keep)])
    return target
