"""Pitch, roll, focal length and height errors of estimated cameras against a calibration, as a table.

Each estimated camera is either the one a lift wrote (``--npz OUT.npz``: its ``cameras``, in the estimated world)
or estimated here from a view's 2D keypoints (``--keypoints FOLDER``, an OpenPose folder or keypoint file, the
same code ``lift`` runs without ``--cams``). The calibration's z = 0 is its floor.

    python tools/camera_errors.py data/video/pose2sim-balancing/calib_pose2sim.toml \\
        --keypoints data/video/pose2sim-balancing/openpose-body25b/cam0{1,2,3,4}_json
    python tools/camera_errors.py calib.toml --npz out/cam01/cam01.npz          # the camera a lift wrote
    python tools/camera_errors.py calib.toml --keypoints out/demo/demo.npz     # estimated from its 2D keypoints
"""

from __future__ import annotations

import argparse
from pathlib import Path

from platypose.lifting.calibration import load_calibration
from platypose.lifting.calibration.matching import match_views
from platypose.lifting.calibration.pose_above_floor import pose_of, posed_camera


def estimated_cameras(args) -> list[tuple[str, object, str]]:
    """(view name, estimated camera, how) of every input."""
    found = []
    for path in args.npz or []:
        from platypose.exporters.npz import read_npz

        for camera in read_npz(path).cameras:
            found.append((camera.name, camera, "lift"))
    for path in args.keypoints or []:
        from platypose.detectors.sources.keypoint_source import read_keypoints
        from platypose.lifting.calibration.one_view import fit_view

        name, keypoints, times, size = _keypoints(Path(path), read_keypoints)
        camera, estimate, note = fit_view(name, keypoints, times, size, {})
        if camera is None and estimate is not None:  # shown all the same, with why lift would not use it
            e = estimate
            camera = posed_camera(name, size, e.focal_px, e.pitch_deg, e.roll_deg, e.height_m)
        found.append((name, camera, note))
    return found


def _keypoints(path: Path, read_keypoints) -> tuple[str, object, object, tuple[int, int]]:
    """(view name, keypoints (T, P, 17, 3), frame times, image size) of a keypoint source or a lift's npz (its
    first view's 2D keypoints)."""
    if path.suffix == ".npz":
        from platypose.exporters.npz import read_npz

        try:
            result = read_npz(path)
        except Exception:  # not a lift's npz: a keypoint file
            result = None
        if result is not None:
            camera = result.cameras[0]
            return camera.name, result.keypoints2d[0].transpose(1, 0, 2, 3), result.frame_times, camera.size
    track = read_keypoints(path)
    return path.name, track.keypoints, track.frame_times, track.image_size


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("calibration")
    parser.add_argument("--npz", nargs="*", help="lift outputs whose cameras to measure")
    parser.add_argument("--keypoints", nargs="*", help="keypoint folders or files to estimate a camera from")
    args = parser.parse_args()
    calibration = load_calibration(args.calibration)
    print(f"{'view':<12}{'pitch off':>10}{'roll off':>10}{'focal off':>10}{'height off':>11}  estimate")
    for name, camera, how in estimated_cameras(args):
        if camera is None:
            print(f"{name:<12}{how}")
            continue
        pairs = match_views(calibration.names, [name], allow_missing=True)
        truth = pose_of(calibration.camera(next(iter(pairs))))
        got = pose_of(camera)
        print(
            f"{name:<12}{got['pitch_deg'] - truth['pitch_deg']:>+10.1f}{got['roll_deg'] - truth['roll_deg']:>+10.1f}"
            f"{100 * (got['focal_px'] / truth['focal_px'] - 1):>+9.0f}%{100 * (got['height_m'] / truth['height_m'] - 1):>+10.0f}%"
            f"  pitch {got['pitch_deg']:.1f} roll {got['roll_deg']:.1f} focal {got['focal_px']:.0f} px "
            f"height {got['height_m']:.2f} m ({how})"
        )


if __name__ == "__main__":
    main()
