"""What detecting every N-th frame (``--stride N``) costs in accuracy, against detecting every frame.

    .venv/bin/python tools/stride_accuracy.py OUT/clip.detections.npz --fps 30 --size 994x1768 --strides 2,3

The detections cache of a stride-1 run (``platypose detect`` / ``lift`` write ``<video>.detections.npz``
beside their outputs) holds every frame's MoveNet people. Detection is per frame, so the stride-N run
is exactly every N-th of those frames; it is tracked again (as ``--stride N`` would), and compared:

- keypoints: each stride-N track is matched to the stride-1 track with the same detections on the
  frames both have; its keypoints are interpolated linearly in time onto the skipped frames (as
  lifting resamples them) and compared with the detections there: median and 95th percentile pixel
  error over joints seen in both, and the share of skipped frames of a track where it is seen at all;
- lift (``--lift-seconds``, default 10): both tracks of the largest person lifted with the shipped prior
  (50 hypotheses, one default camera, as ``platypose lift`` without ``--cams``), compared on the frames
  both have: median over frames and joints of the distance between their hypotheses' medians, root-relative
  (pose) and absolute (placement), in mm. For scale: the same distances between the stride-1 lift and
  one with another seed (the lift's own sampling noise), and the stride-1 hypotheses' median distance
  to their median (its uncertainty).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from platypose.detectors.cache import read_detections
from platypose.detectors.keypoints import to_our_joints
from platypose.detectors.tracking.tracker import track_detections
from platypose.lifting.timebase import resample_keypoints


def matched_tracks(full: np.ndarray, sub: np.ndarray, every: int) -> dict[int, int]:
    """Stride-N track -> stride-1 track with the same keypoints on the common frames (full (T, P, 17, 3),
    sub (T', P', 17, 3) at every ``every``-th frame)."""
    common = full[::every][: len(sub)]
    pairs = {}
    for q in range(sub.shape[1]):
        seen = sub[:, q, :, 2] > 0
        best, hits = -1, 0
        for p in range(full.shape[1]):
            same = seen & np.isclose(common[:, p, :, 0], sub[:, q, :, 0], atol=1e-3)
            if same.sum() > hits:
                best, hits = p, int(same.sum())
        if best >= 0:
            pairs[q] = best
    return pairs


def keypoint_errors(full, times, sub, sub_times, pairs) -> tuple[np.ndarray, float]:
    """Pixel errors of the interpolated stride-N keypoints at the skipped frames, and the share of skipped
    frames (where the stride-1 track is seen) the stride-N track covers."""
    errors, covered, seen_frames = [], 0, 0
    skipped = np.setdiff1d(np.arange(len(times)), np.searchsorted(times, sub_times))
    skipped = skipped[(times[skipped] >= sub_times[0]) & (times[skipped] <= sub_times[-1])]
    for q, p in pairs.items():
        guess = resample_keypoints(sub[:, q], sub_times, times[skipped])  # (S, 17, 3)
        truth = full[skipped, p]
        both = (guess[..., 2] > 0) & (truth[..., 2] > 0)
        seen = (truth[..., 2] > 0).any(-1)
        seen_frames += int(seen.sum())
        covered += int((seen & (guess[..., 2] > 0).any(-1)).sum())
        errors.append(np.linalg.norm(guess[..., :2] - truth[..., :2], axis=-1)[both])
    return np.concatenate(errors), covered / max(seen_frames, 1)


def lift_track(prior, keypoints, times, image_size, seed: int = 0):
    """Hypotheses (N, T, 17, 3) of one track (T, 17, 3) with the default camera, 50 hypotheses."""
    from platypose.lifting.calibration.defaults import default_camera
    from platypose.lifting.settings import SamplerConfig
    from platypose.lifting.tracks.stream import lift_tracks

    camera = default_camera("stride", *image_size)
    return lift_tracks(
        prior, [camera], keypoints[None, :, None], times, SamplerConfig(samples=50, seed=seed)
    ).hypotheses[0]


def median_gaps(lifted: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """Median distance (mm) between two motions (T, 17, 3): root-relative (pose) and absolute (placement)."""
    both = np.isfinite(lifted).all(-1) & np.isfinite(reference).all(-1)
    place = np.linalg.norm(lifted - reference, axis=-1)
    pose = np.linalg.norm((lifted - lifted[:, :1]) - (reference - reference[:, :1]), axis=-1)
    return float(np.median(pose[both]) * 1000), float(np.median(place[both]) * 1000)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("detections", type=Path, help="a stride-1 detections cache (*.detections.npz)")
    parser.add_argument("--fps", type=float, required=True, help="the video's frame rate")
    parser.add_argument("--size", required=True, help="image HEIGHTxWIDTH, e.g. 994x1768")
    parser.add_argument("--strides", default="2,3", help="strides to compare with 1")
    parser.add_argument("--lift-seconds", type=float, default=10.0, help="seconds of the largest track lifted (0: no)")
    args = parser.parse_args()
    size = tuple(int(v) for v in args.size.lower().split("x"))
    _, detections, indices = read_detections(args.detections)
    ours = [to_our_joints(people, "coco17") for people in detections]
    times = indices / args.fps
    full = track_detections(ours, times, size, "stride 1")
    lifted = None
    if args.lift_seconds > 0:
        from platypose.lifting.prior.model import load_prior

        prior, _ = load_prior()
        sizes = [np.nansum(np.ptp(full.keypoints[:, p, :, 1], axis=1)) for p in range(full.num_persons)]
        person = int(np.argmax(sizes))
        seen = np.nonzero((full.keypoints[:, person, :, 2] > 0).any(-1))[0]
        window = (times >= times[seen[0]]) & (times < times[seen[0]] + args.lift_seconds)
        base = lift_track(prior, full.keypoints[window, person], times[window], size)
        base_median = np.median(base, axis=0)
        spread = np.nanmedian(np.linalg.norm(base - base_median, axis=-1)) * 1000
        other = np.median(lift_track(prior, full.keypoints[window, person], times[window], size, seed=1), axis=0)
        pose, place = median_gaps(other, base_median)
        print(
            f"stride 1: {full.num_persons} tracks; track {person} lifted over {window.sum()} frames: hypotheses "
            f"{spread:.0f} mm (median) from their median; another seed's median {pose:.0f} mm (pose), "
            f"{place:.0f} mm (placement) from this one's"
        )

        def lifted(sub, q: int, every: int) -> tuple[float, float]:
            part = window[::every]
            motion = np.median(lift_track(prior, sub.keypoints[part, q], times[::every][part], size), axis=0)
            return median_gaps(motion, base_median[np.searchsorted(times[window], times[::every][part])])

    print("| stride | tracks | px error median | px error 95 % | skipped frames covered | pose mm | placement mm |")
    print("|---|---|---|---|---|---|---|")
    for every in (int(s) for s in args.strides.split(",")):
        sub = track_detections(ours[::every], times[::every], size, f"stride {every}")
        pairs = matched_tracks(full.keypoints, sub.keypoints, every)
        errors, covered = keypoint_errors(full.keypoints, times, sub.keypoints, times[::every], pairs)
        q = next((q for q, p in pairs.items() if lifted is not None and p == person), None)
        pose, place = lifted(sub, q, every) if q is not None else (float("nan"), float("nan"))
        print(
            f"| {every} | {sub.num_persons} | {np.median(errors):.1f} | {np.percentile(errors, 95):.1f} | "
            f"{covered:.0%} | {pose:.0f} | {place:.0f} |"
        )


if __name__ == "__main__":
    main()
