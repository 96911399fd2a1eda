"""What the bundled detector costs per frame and how accurate it is, by input size and frame stride.

    .venv/bin/python tools/cost_accuracy.py [VIDEO REFERENCE] [--sizes 256,320,384] [--strides 1,2,3] [--max-frames N]

Defaults: the bundled Pose2Sim balancing take, cam01, against its shipped OpenPose BODY_25B keypoints
(as ``platypose detect VIDEO --compare REFERENCE``). One onnxruntime thread; every frame is decoded once
and given to each size's MoveNet in turn (alternated, so machine load falls on all sizes alike), each call
timed in process CPU time (``time.process_time``: the machine is shared, wall time is noise). Detection
is per frame and stateless, so stride N is exactly every N-th frame's detections; they are tracked again
(as ``--stride N`` does) and interpolated onto every frame as lifting resamples a track
(``lifting.timebase.resample_keypoints``), then compared with the reference on every frame
(``detectors.tracking.compare.distances_to_reference``: the reference's main person against the nearest track).

Printed per size and stride: the detector call (median CPU ms), CPU ms per video frame (median decode +
detector call / N + tracking), the compare median and 90th percentile px, and the frames where the person
is found. The model's input shape says whether frames could share a call (a batch dimension of 1 cannot).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from platypose.detectors.keypoints import to_our_joints
from platypose.detectors.models.contracts import load_detector
from platypose.detectors.sources.keypoint_source import read_keypoints
from platypose.detectors.sources.video import frame_times, iter_frames, video_info
from platypose.detectors.tracking.compare import distances_to_reference
from platypose.detectors.tracking.tracker import persons_to_keep, track_detections
from platypose.lifting.timebase import resample_keypoints

REPO = Path(__file__).resolve().parents[1]
TAKE = REPO / "data" / "video" / "pose2sim-balancing"


def detect_all(video: Path, sizes: list[int], max_frames: int | None) -> tuple[dict, dict, list[float]]:
    """Every frame through each size's detector: detections per size (list over frames), the detector calls'
    CPU ms per size, and the decoding CPU ms per frame."""
    detectors = {size: load_detector(threads=1, movenet_size=size) for size in sizes}
    found = {size: [] for size in sizes}
    cpu = {size: [] for size in sizes}
    decode = []
    frames = iter_frames(video, max_frames=max_frames)
    while True:
        start = time.process_time()
        item = next(frames, None)
        decode.append((time.process_time() - start) * 1000)
        if item is None:
            break
        for size, detector in detectors.items():
            start = time.process_time()
            people = detector(item[1])
            cpu[size].append((time.process_time() - start) * 1000)
            found[size].append(np.asarray(people, dtype=np.float32))
    return found, cpu, decode[:-1]


def strided_distances(detections: list[np.ndarray], times: np.ndarray, stride: int, image_size, reference, main):
    """Track every ``stride``-th frame's detections, resample onto every frame: distances (T_ref, 17) to the
    reference's person ``main`` and the tracking CPU ms."""
    start = time.process_time()
    ours = [to_our_joints(people, "coco17") for people in detections[::stride]]
    tracks = track_detections(ours, times[::stride], image_size, f"stride {stride}")
    tracking_ms = (time.process_time() - start) * 1000
    if tracks.num_frames > 1 and stride > 1:
        every = resample_keypoints(tracks.keypoints, tracks.frame_times, times)
        tracks = replace(tracks, keypoints=every, frame_times=times)
    return distances_to_reference(tracks, reference, main), tracking_ms


def main() -> None:
    """Print the size x stride table for one video against its reference keypoints."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("video", type=Path, nargs="?", default=TAKE / "cam01.mp4")
    parser.add_argument("reference", type=Path, nargs="?", default=TAKE / "openpose-body25b" / "cam01_json")
    parser.add_argument("--sizes", default="256,320,384", help="MoveNet input sizes (longer side, px)")
    parser.add_argument("--strides", default="1,2,3", help="detect every N-th frame")
    parser.add_argument("--max-frames", type=int, default=None)
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    strides = [int(s) for s in args.strides.split(",")]

    info = video_info(args.video)
    reference = read_keypoints(args.reference, fps=info.fps, image_size=info.image_size)
    main_person = int(persons_to_keep([reference], "largest")[0])
    detections, cpu, decode = detect_all(args.video, sizes, args.max_frames)
    times = frame_times(args.video)[: len(decode)]
    session = load_detector(threads=1).session
    print(
        f"{args.video} against {args.reference}: {len(decode)} frames, image {info.image_size[1]}x{info.image_size[0]} px"
    )
    print(f"model input {session.get_inputs()[0].shape}, output {session.get_outputs()[0].shape}")
    print(f"load average {' '.join(Path('/proc/loadavg').read_text().split()[:3])}, {os.cpu_count()} cores, 1 thread")
    print(f"decoding: {statistics.median(decode):.1f} ms CPU per frame (median)\n")
    print(
        "| size | stride | detector call ms CPU | ms CPU per video frame | compare median px | p90 px | frames found |"
    )
    print("|---|---|---|---|---|---|---|")
    for size in sizes:
        call = statistics.median(cpu[size])
        for stride in strides:
            distances, tracking_ms = strided_distances(
                detections[size], times, stride, info.image_size, reference, main_person
            )
            per_frame = statistics.median(decode) + call / stride + tracking_ms / len(decode)
            seen = np.isfinite(distances).any(axis=1)
            print(
                f"| {size} | {stride} | {call:.1f} | {per_frame:.1f} | {np.nanmedian(distances):.1f} | "
                f"{np.nanpercentile(distances, 90):.1f} | {seen.sum()}/{len(seen)} |"
            )


if __name__ == "__main__":
    main()
