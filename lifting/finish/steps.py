"""Everything that happens to a take after sampling, in order, behind :func:`finish_take`.

1. one grounded view: each solved root's depth steadied along its ray (:mod:`platypose.lifting.finish.steady_depth`);
2. bodies: one shape per hypothesis over the clip, one depth branch per limb, knees, elbows and head within
   the limits a body holds (:func:`platypose.lifting.finish.rigid.rigid_person`);
3. the median motion's reprojection against the keypoints, per view
   (:func:`platypose.lifting.finish.reprojection.report_reprojection`);
4. plausibility of each person (:mod:`platypose.lifting.checks.plausibility`), said in one line each, with the
   first gap after which the body the keypoints give is not the one before it (:mod:`platypose.lifting.checks.gap_size`,
   measured before the bodies are made one);
5. on an estimated floor, every output moved into the estimated world (:mod:`platypose.lifting.finish.world`).

The arrays are changed in place; what the result's ``meta`` keeps is returned.
"""

from __future__ import annotations

import os
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.checks.flags import flag_text, person_lines
from platypose.lifting.checks.gap_size import body_sizes, size_after_gap
from platypose.lifting.checks.plausibility import plausibility
from platypose.lifting.finish.reprojection import report_reprojection
from platypose.lifting.finish.rigid import rigid_person
from platypose.lifting.finish.steady_depth import steady_person
from platypose.lifting.finish.world import level_on_floor
from platypose.lifting.floor import Floor
from platypose.lifting.job_log import JobLog
from platypose.lifting.take import Take


@dataclass(frozen=True)
class FinishedTake:
    """What finishing a take leaves besides its arrays: the cameras the outputs are in (moved into the estimated
    world where the floor was estimated), and the ``meta`` entries ``floor``, ``reprojection_px``, ``plausibility``
    (per person) and ``rigid_bones`` (per person)."""

    cameras: tuple[Camera, ...]
    floor: dict | None
    reprojection_px: dict[str, float]
    plausibility: list[dict]
    rigid_bones: dict[str, dict]


def finish_take(
    take: Take, *, hypotheses, median, fps: float, floor: Floor | None, log: JobLog, workers: int | None = None
) -> FinishedTake:
    """Finish the sampled ``hypotheses`` (P, N, T, 17, 3) and ``median`` (P, T, 17, 3) of ``take`` (its persons
    ``track_ids`` seen as ``keypoints`` (C, T, P, 17, 3) on ``times`` at ``fps`` by ``cameras``, their root paths
    ``roots``: None solved per hypothesis) on ``floor``, the one the sampler grounded them on, with its meta (None:
    no floor). Each step is logged. Steps 1 and 2 (and the gap check) run person by person on ``workers`` threads
    (None: one per core this process may use): each writes its own person's slices only, so the arrays come out
    as one thread makes them, and numpy leaves the interpreter lock while it computes (docs/results.md: two
    threads finished the 60 s clip's nine persons in 0.67 of one thread's time, arrays identical)."""
    workers = usable_cores() if workers is None else workers
    keypoints, track_ids, cameras = take.keypoints, take.track_ids, list(take.cameras)
    steady = len(cameras) == 1 and floor is not None  # one grounded view: steady each solved root's depth

    def person(p: int) -> tuple[str | None, dict | None, dict, str]:
        """Person p's steps: (what steadying said, the gap check, the body's stats, what making it said)."""
        track, said = track_ids[p], None
        if steady and take.roots[p] is None:
            seen = (np.nan_to_num(keypoints[0, :, p, :, 2]) > 0).sum(axis=-1)  # joints seen per frame
            moved = steady_person(hypotheses, p, cameras[0], fps, floor, seen, times=take.times)
            said = f"person {track}: depth steadied, pelvis moved along its ray by up to {moved:.2f} m"
        seen = (np.nan_to_num(keypoints[:, :, p, :, 2]) > 0).sum(axis=-1).max(axis=0)  # joints the best view sees
        gap = size_after_gap(body_sizes(hypotheses, p), seen, fps)  # before the bodies are made one
        began = time.perf_counter()
        stats = rigid_person(hypotheses, median, keypoints, cameras, p, fps, floor)
        made = (
            f"person {track}: made a body in {time.perf_counter() - began:.1f} s (the sampler's median motion "
            f"stretched its bones by up to {1000 * stats['stretch_m']:.0f} mm); its joints moved "
            f"{1000 * stats['moved_m']:.0f} mm (median), {1000 * stats['moved_max_m']:.0f} mm at most"
        )
        return said, gap, stats, made

    indices = range(len(track_ids))
    if workers > 1 and len(track_ids) > 1:
        # warnings.catch_warnings is not thread-safe: the steps' own "ignore RuntimeWarning" (an absent frame's median
        # of nothing is NaN) would race between the threads and let warnings through; set once here, around them
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            with ThreadPoolExecutor(min(workers, len(track_ids)), thread_name_prefix="platypose-finish") as pool:
                done = list(pool.map(person, indices))
    else:
        done = [person(p) for p in indices]
    for said in (said for said, _, _, _ in done if said is not None):
        log(said)
    gaps = {p: gap for p, (_, gap, _, _) in enumerate(done)}  # the first gap after which the body is not the same
    rigid = {f"p{track}": stats for track, (_, _, stats, _) in zip(track_ids, done)}
    for _, _, _, made in done:
        log(made)
    report = report_reprojection(median, keypoints, cameras, log)
    persons = plausibility(hypotheses, keypoints, floor, fps, median=median, cameras=cameras)
    for p, (track, person) in enumerate(zip(track_ids, persons)):
        person["track_id"] = int(track)
        if gaps[p] is not None:
            person.update(size_after_gap=gaps[p], flags=[*person["flags"], "size after gap"])
            person["flag_text"] = flag_text(person)
    for line in person_lines(persons, track_ids):  # said once: the console shows them from the result
        log(line)
    floor_entry = None if floor is None else floor.as_dict()
    if floor is not None and floor.source == "estimated":  # outputs in the estimated world: z = 0 the floor, z up
        camera, floor_entry = level_on_floor(floor, cameras[0], (hypotheses, median))
        cameras = [camera]
        log(f"outputs in the {floor_entry['frame']}")
    return FinishedTake(tuple(cameras), floor_entry, report, persons, rigid)


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the system has one, as Linux does; else all)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
