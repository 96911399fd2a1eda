"""A video as a lens of known radial distortion would have filmed it: every frame bent by the division model's k
(zoomed just enough to fill the frame: :func:`platypose.lifting.calibration.scene.distortion.bent_image`), for
checking the camera from the scene and the whole lift on real footage through a wide lens.

    python tools/bent_video.py data/video/pose2sim-balancing/cam03.mp4 -0.4 /tmp/cam03-bent.mp4

prints the zoom (the bent video's focal length is the original's times it). The frame rate is kept; the picture is
written with OpenCV's mp4v codec.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2

from platypose.lifting.calibration.scene.distortion import bent_image
from platypose.media import iter_timed_frames, video_info


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("video", type=Path)
    parser.add_argument("k", type=float, help="the division model's k (negative: barrel)")
    parser.add_argument("out", type=Path)
    args = parser.parse_args()
    info = video_info(args.video)
    height, width = info.image_size
    writer = cv2.VideoWriter(str(args.out), cv2.VideoWriter_fourcc(*"mp4v"), info.fps, (width, height))
    zoom = 1.0
    for _, _, frame in iter_timed_frames(args.video, fmt="bgr24"):
        bent, zoom = bent_image(frame, args.k)
        writer.write(bent)
    writer.release()
    print(f"{args.out}: {args.video.name} bent by k = {args.k:+.2f}, zoomed {zoom:.3f} times")


if __name__ == "__main__":
    main()
