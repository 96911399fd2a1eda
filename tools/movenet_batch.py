"""Can the bundled MoveNet run frames in batches, and does it pay? Also: what the video reader's per-frame arrays cost.

    OMP_NUM_THREADS=1 .venv/bin/python tools/movenet_batch.py [--frames 32] [--batches 4,8] [--threads 1,2]

The bundled ``movenet-multipose.onnx`` takes ``[1, H, W, 3]``. Its network (MobileNetV2-FPN and six
CenterNet heads) reads the batch from the tensor shapes, but its decoding (centre top-k, keypoint
gathers) squeezes axis 0 and reshapes to fixed ``[6, 17, 2]`` / ``[1, 6, 2]`` and gathers batch index 0
from constants: it is batch-1 by construction. So the graph is cut at the six head outputs into a
network with a free batch dimension and the unchanged batch-1 decoder, and the two are compared with
the whole model on real frames (the sports2d demo, letterboxed as the detector does):

- identity: the rows of every frame from the cut pair equal the whole model's (max absolute difference);
- speed: per frame, the whole model frame by frame against the batched network plus the per-frame
  decoder, alternated, ``--rounds`` rounds, median wall and process CPU ms per frame, at each thread count;
- decoding: PyAV's ``to_ndarray`` (a new array per frame) against converting into one reused array.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "detectors" / "models" / "movenet-multipose.onnx"
VIDEO = REPO / "data" / "video" / "sports2d-demo" / "demo.mp4"
HEAD_OPS = ("kpt_regress_0/conv2d_8", "kpt_offset_0/conv2d_9", "kpt_heatmap_0/conv2d_7", "center_0/conv2d_4")
HEAD_OPS += ("box_scale_0/conv2d_5", "box_offset_0/conv2d_6")


def head_outputs(model) -> list[str]:
    """The six head convolutions' outputs, where the network ends and the batch-1 decoding starts."""
    names = [n.output[0] for n in model.graph.node if n.op_type == "Conv" and any(h in n.name for h in HEAD_OPS)]
    if len(names) != len(HEAD_OPS):
        raise SystemExit(f"{MODEL}: expected {len(HEAD_OPS)} head convolutions, found {len(names)}")
    return names


def batch_one_constants(model) -> list[str]:
    """Reshape targets and Squeeze/Unsqueeze on axis 0 of ``model``: the places a batch of 1 is built in."""
    from onnx import numpy_helper

    values = {i.name: numpy_helper.to_array(i) for i in model.graph.initializer}
    found = []
    for node in model.graph.node:
        if node.op_type == "Reshape" and node.input[1] in values:
            found.append(f"Reshape {node.name} -> {values[node.input[1]].tolist()}")
        if node.op_type in ("Squeeze", "Unsqueeze") and len(node.input) > 1 and node.input[1] in values:
            if 0 in values[node.input[1]].tolist():
                found.append(f"{node.op_type} {node.name} axis 0")
    return found


def split_model(folder: Path) -> tuple[Path, Path, list[str]]:
    """Write the batch-free network and the batch-1 decoder of the bundled model into ``folder``."""
    import onnx
    from onnx.utils import Extractor

    model = onnx.shape_inference.infer_shapes(onnx.load(str(MODEL)))
    heads = head_outputs(model)
    extractor = Extractor(model)
    network = extractor.extract_model([model.graph.input[0].name], heads)
    decoder = extractor.extract_model(heads, [o.name for o in model.graph.output])
    print(f"network: {len(network.graph.node)} nodes; decoder: {len(decoder.graph.node)} nodes")
    print("batch-1 places in the network:", batch_one_constants(network) or "none")
    print(f"batch-1 places in the decoder: {len(batch_one_constants(decoder))}, e.g.", batch_one_constants(decoder)[:4])
    for tensor in [*network.graph.input, *network.graph.output]:
        tensor.type.tensor_type.shape.dim[0].dim_param = "batch"
    del network.graph.value_info[:]  # shapes inferred for a batch of 1
    onnx.checker.check_model(network)
    paths = folder / "network.onnx", folder / "decoder.onnx"
    onnx.save(network, str(paths[0]))
    onnx.save(decoder, str(paths[1]))
    return paths[0], paths[1], heads


def real_inputs(count: int) -> np.ndarray:
    """The first ``count`` demo frames as the detector feeds them: letterboxed RGB int32 ``(count, H, W, 3)``."""
    import cv2

    from platypose.detectors.models.letterbox import fit_size, letterbox
    from platypose.detectors.models.movenet import DEFAULT_LONGEST
    from platypose.media import iter_frames

    inputs = []
    for _, image in iter_frames(VIDEO, max_frames=count):
        padded, _ = letterbox(image, fit_size(image.shape[:2], DEFAULT_LONGEST, 32), box_filter=True)
        inputs.append(cv2.cvtColor(padded, cv2.COLOR_BGR2RGB).astype(np.int32))
    return np.stack(inputs)


def per_frame(whole, frames: np.ndarray) -> np.ndarray:
    """The whole model run frame by frame: rows ``(T, 6, 56)``."""
    name = whole.get_inputs()[0].name
    return np.stack([whole.run(None, {name: f[None]})[0][0] for f in frames])


def batched(network, decoder, heads: list[str], frames: np.ndarray, batch: int) -> np.ndarray:
    """The network on ``batch`` frames at a time, then the decoder per frame: rows ``(T, 6, 56)``."""
    name = network.get_inputs()[0].name
    rows = []
    for start in range(0, len(frames), batch):
        maps = network.run(None, {name: frames[start : start + batch]})
        for i in range(len(maps[0])):
            rows.append(decoder.run(None, {h: m[i : i + 1] for h, m in zip(heads, maps)})[0][0])
    return np.stack(rows)


def timed(run) -> tuple[float, float]:
    """Wall and process CPU seconds of ``run()``."""
    wall, cpu = time.perf_counter(), time.process_time()
    run()
    return time.perf_counter() - wall, time.process_time() - cpu


def decode_buffers(count: int, rounds: int) -> None:
    """Per-frame ms of PyAV's conversion into a new array against into one reused array (same pixels)."""
    import av

    with av.open(str(VIDEO)) as container:
        frames = [f for _, f in zip(range(count), container.decode(video=0))]
    reused = None
    fresh_ms, reuse_ms = [], []
    for _ in range(rounds):
        started = time.perf_counter()
        for f in frames:
            f.to_ndarray(format="bgr24")
        fresh_ms.append((time.perf_counter() - started) / count * 1e3)
        started = time.perf_counter()
        for f in frames:
            plane = f.reformat(format="bgr24").planes[0]
            view = np.frombuffer(plane, np.uint8).reshape(f.height, plane.line_size)[:, : f.width * 3]
            reused = np.empty((f.height, f.width * 3), np.uint8) if reused is None else reused
            np.copyto(reused, view)
        reuse_ms.append((time.perf_counter() - started) / count * 1e3)
    same = np.array_equal(reused.reshape(frames[-1].height, -1, 3), frames[-1].to_ndarray(format="bgr24"))
    print(
        f"decode, {frames[0].width}x{frames[0].height}, {count} frames: to_ndarray (new array) "
        f"{statistics.median(fresh_ms):.2f} ms/frame, reformat into one reused array "
        f"{statistics.median(reuse_ms):.2f} ms/frame (median of {rounds}; same pixels: {same})"
    )


def compare(
    paths: tuple[Path, Path, list[str]], frames: np.ndarray, threads: int, batches: list[int], rounds: int
) -> None:
    """Identity and speed of the batched network + per-frame decoder against the whole model, at ``threads``."""
    from platypose.detectors.models.session import open_session

    network_path, decoder_path, heads = paths
    whole = open_session(MODEL, threads)
    network, decoder = open_session(network_path, threads), open_session(decoder_path, threads)
    reference = per_frame(whole, frames)
    runs = {"frame by frame": lambda: per_frame(whole, frames)}
    for batch in batches:
        rows = batched(network, decoder, heads, frames, batch)
        print(f"threads {threads}, batch {batch}: max |rows - whole model's| = {np.abs(rows - reference).max()}")
        runs[f"batch {batch}"] = lambda b=batch: batched(network, decoder, heads, frames, b)
    times = {name: [] for name in runs}
    for _ in range(rounds):
        for name, run in runs.items():
            times[name].append(timed(run))
    for name, values in times.items():
        wall = statistics.median(v[0] for v in values) / len(frames) * 1e3
        cpu = statistics.median(v[1] for v in values) / len(frames) * 1e3
        print(f"threads {threads}, {name}: {wall:.1f} ms/frame wall, {cpu:.1f} ms/frame CPU (median of {rounds})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=32)
    parser.add_argument("--batches", default="4,8")
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    frames = real_inputs(args.frames)
    print(f"{len(frames)} frames of {VIDEO.name}, input {frames.shape[1:]}; load average {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as folder:
        paths = split_model(Path(folder))
        for threads in map(int, args.threads.split(",")):
            compare(paths, frames, threads, [int(b) for b in args.batches.split(",")], args.rounds)
    decode_buffers(args.frames, args.rounds)
    print(f"load average at the end {os.getloadavg()}")


if __name__ == "__main__":
    main()
