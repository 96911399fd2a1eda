"""Pitch, roll and focal length of each video's camera from its scene's lines, against a calibration.

Each video's camera is estimated from its own frames alone (no detections, no metadata:
:func:`platypose.detectors.sources.scene_frames.video_scene_camera`) and compared with the calibration's camera of the
same name (pitch and roll as :func:`platypose.lifting.calibration.pose_above_floor.pose_of` defines them). Where
the calibration is a guess (``--guess``: the sports2d demo's), only the values are shown.

    python tools/scene_camera_figures.py                        # the bundled balancing cameras and the demo
    python tools/scene_camera_figures.py --people               # the same, their bundled people masked
    python tools/scene_camera_figures.py --fused                # masked, and checked against their verticals
    python tools/scene_camera_figures.py CALIB.toml VIDEO...    # other videos
    python tools/scene_camera_figures.py --bend -0.4 -0.2 0.1   # the balancing cameras through known lenses

With ``--people`` the bundled detections mask the people (the balancing cameras' OpenPose folders, the demo's
MoveNet detections); the uncertainties are shown as one standard deviation. With ``--fused`` the people also check
the lines' roll and pitch (:func:`platypose.lifting.calibration.scene.view_camera.assumed_camera`, what ``lift``
uses): a second line per video gives the fused camera against the calibration and each source used or dropped.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from platypose.detectors.cache import read_detections
from platypose.detectors.sources.keypoint_source import read_keypoints
from platypose.detectors.sources.scene_frames import sample_frames, video_scene_camera
from platypose.lifting.calibration import load_calibration
from platypose.lifting.calibration.matching import match_views
from platypose.lifting.calibration.pose_above_floor import pose_of
from platypose.lifting.calibration.scene.distortion import bent_image
from platypose.lifting.calibration.scene.estimate import scene_camera
from platypose.lifting.calibration.scene.view_camera import assumed_camera
from platypose.media import video_info

BALANCING = Path("data/video/pose2sim-balancing")
DEMO = Path("data/video/sports2d-demo")


def bundled_people(video: Path) -> list[np.ndarray] | np.ndarray | None:
    """The bundled people of ``video``, per frame (P, J, 3), or None where none are bundled."""
    folder = video.parent / "openpose-body25b" / f"{video.stem}_json"
    if folder.is_dir():
        return read_keypoints(folder).keypoints
    detections = video.parent / "movenet-detections.npz"
    if detections.is_file():
        _, per_frame, indices = read_detections(detections)
        people = [np.zeros((0, 17, 3))] * (int(indices.max()) + 1 if len(indices) else 0)
        for index, found in zip(indices, per_frame):
            people[int(index)] = found
        return people
    return None


def fused_row(video: Path, scene, people: tuple[np.ndarray, np.ndarray], truth: dict, guess: bool) -> str:
    """The second row of ``--fused``: the camera fused from ``scene`` and the ``people`` of ``video`` against
    ``truth`` (values only where it is a ``guess``; ``people``: keypoints (T, P, 17, 3) and times (T,)), and each
    quantity's sources used and dropped."""
    found = assumed_camera(video.stem, video_info(video).image_size, scene, None, people)
    used = pose_of(found.camera)
    off = ""
    if not guess:
        focal_off = f"{100 * (used['focal_px'] / truth['focal_px'] - 1):+.1f}%"
        pitch_off, roll_off = used["pitch_deg"] - truth["pitch_deg"], used["roll_deg"] - truth["roll_deg"]
        off = f"{pitch_off:>+10.1f}{roll_off:>+10.1f}{focal_off:>10}"
    said = []
    for key in ("roll_deg", "pitch_deg"):
        entry = found.record[key]
        said += [f"{key[:-4]} {e['value']:.1f} +- {e['sd']:.1f} ({e['source']})" for e in entry["used"]]
        said += [
            f"{key[:-4]} {e['value']:.1f} +- {e['sd']:.1f} ({e['source']}) dropped: {e['why']}"
            for e in entry["dropped"]
        ]
    people_note = found.record.get("people", {}).get("note")
    return f"{'  fused':<8}{off:<30}{'':>8}  " + "; ".join(said + ([people_note] if people_note else []))


def rows(calibration: Path, videos: list[Path], guess: bool, people: bool = False, fused: bool = False) -> None:
    """Print one row per video (``people``: its bundled people masked; ``fused``: and a second row, the camera
    fused with their verticals)."""
    cameras = load_calibration(calibration)
    for video in videos:
        name = next(iter(match_views(cameras.names, [video.stem], allow_missing=True)))
        truth = pose_of(cameras.camera(name))
        start = time.perf_counter()
        bundled = bundled_people(video) if people or fused else None
        got = video_scene_camera(video, bundled)
        took = time.perf_counter() - start
        if got.problem is not None:
            print(f"{video.stem:<8}{'':>10}{'':>10}{'':>10}{took:>7.1f}s  {got.problem}")
            continue
        focal = "not measured" if got.focal_px is None else f"{got.focal_px:.0f} px"
        focal_sd = "" if got.focal_px is None else f" +- {100 * got.sd['focal_px'] / got.focal_px:.0f} %"
        if guess:
            off = f"{'':>10}{'':>10}{'':>10}"
        else:
            focal_off = "" if got.focal_px is None else f"{100 * (got.focal_px / truth['focal_px'] - 1):+.1f}%"
            off = (
                f"{got.pitch_deg - truth['pitch_deg']:>+10.1f}{got.roll_deg - truth['roll_deg']:>+10.1f}{focal_off:>10}"
            )
        print(
            f"{video.stem:<8}{off}{took:>7.1f}s  pitch {got.pitch_deg:.1f} +- {got.sd['pitch_deg']:.1f} "
            f"(calibration {truth['pitch_deg']:.1f}), roll {got.roll_deg:.1f} +- {got.sd['roll_deg']:.1f} "
            f"({truth['roll_deg']:.1f}), focal {focal}{focal_sd} ({truth['focal_px']:.0f} px); "
            f"{got.segments} segments; lens distortion k {got.distortion:+.2f}"
            + (f"; {got.focal_note}" if got.focal_note else "")
        )
        folder = video.parent / "openpose-body25b" / f"{video.stem}_json"
        if fused and folder.is_dir():
            tracked = read_keypoints(folder)
            print(fused_row(video, got, (tracked.keypoints, tracked.frame_times), truth, guess))
        elif fused:
            print(f"{'  fused':<8}  not fused: no tracked people bundled (their verticals need each person's frames)")


def bent_rows(calibration: Path, videos: list[Path], bends: list[float]) -> None:
    """Print one row per video and lens: 8 of its frames bent by the division model's ``k`` (zoomed to fill the
    frame: :func:`platypose.lifting.calibration.scene.distortion.bent_image`), the distortion found, and pitch, roll
    and focal length against the calibration's (its focal length times the zoom)."""
    cameras = load_calibration(calibration)
    for video in videos:
        truth = pose_of(cameras.camera(next(iter(match_views(cameras.names, [video.stem], allow_missing=True)))))
        _, frames = sample_frames(video, 8)
        for k in bends:
            bent = [bent_image(frame, k) for frame in frames]
            start = time.perf_counter()
            got = scene_camera([image for image, _ in bent])
            took = time.perf_counter() - start
            if got.problem is not None:
                print(f"{video.stem:<8}{'':>30}{took:>7.1f}s  k {k:+.2f}: {got.problem}")
                continue
            focal = (
                "" if got.focal_px is None else f"{100 * (got.focal_px / (truth['focal_px'] * bent[0][1]) - 1):+.1f}%"
            )
            print(
                f"{video.stem:<8}{got.pitch_deg - truth['pitch_deg']:>+10.1f}{got.roll_deg - truth['roll_deg']:>+10.1f}"
                f"{focal:>10}{took:>7.1f}s  lens k {k:+.2f} (zoom {bent[0][1]:.2f}): found {got.distortion:+.3f}"
                + (f"; {got.focal_note}" if got.focal_note else "")
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("calibration", nargs="?", type=Path)
    parser.add_argument("videos", nargs="*", type=Path)
    parser.add_argument("--guess", action="store_true", help="the calibration is a guess: show values only")
    parser.add_argument("--people", action="store_true", help="mask the bundled people")
    parser.add_argument("--fused", action="store_true", help="mask them and fuse with their verticals")
    parser.add_argument(
        "--bend", type=float, nargs="+", metavar="K", help="bend 8 frames of each by these lenses (division model k)"
    )
    args = parser.parse_args()
    print(f"{'view':<8}{'pitch off':>10}{'roll off':>10}{'focal off':>10}{'time':>8}  estimate")
    if args.bend:
        calibration = args.calibration or BALANCING / "calib_pose2sim.toml"
        bent_rows(calibration, args.videos or sorted(BALANCING.glob("cam0?.mp4")), args.bend)
    elif args.calibration is None:
        rows(BALANCING / "calib_pose2sim.toml", sorted(BALANCING.glob("cam0?.mp4")), False, args.people, args.fused)
        rows(DEMO / "Calib_demo.toml", [DEMO / "demo.mp4"], True, args.people, args.fused)
    else:
        rows(args.calibration, args.videos, args.guess, args.people, args.fused)


if __name__ == "__main__":
    main()
