"""The per-view reprojection report of `platypose lift`: a view far off its keypoints is named in a warning."""

import warnings

import numpy as np
from demo_tracks import demo_take

from platypose.lifting.camera import project
from platypose.lifting.finish.steps import report_reprojection
from platypose.lifting.job_log import JobLog
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.timebase import resample


def test_a_view_far_off_its_keypoints_is_warned_about(real_clips):
    climb = next(m for m in real_clips if "climb" in m.name)
    motion = resample(climb.joints, climb.fps, 30.0)[:60]
    motion = motion - motion[:, 0].mean(0) + [0.0, 0.0, 1.0]
    cams = ring_cameras(4)[:2]
    pixels = np.stack([project(motion, c) for c in cams])  # (C, T, 17, 2)
    pixels[1] += [60.0, 80.0]  # view 1 is 100 px off: as with a wrong calibration
    keypoints = np.concatenate([pixels, np.ones(pixels.shape[:-1] + (1,))], -1)[:, :, None]  # (C, T, P=1, 17, 3)
    log = JobLog()
    report = report_reprojection(motion[None], keypoints, cams, log)
    assert list(report) == [c.name for c in cams]
    assert report[cams[0].name] < 0.01 and abs(report[cams[1].name] - 100.0) < 0.01
    assert len(log.warnings) == 1 and cams[1].name in log.warnings[0] and "calibration" in log.warnings[0]
    single = JobLog()
    assert report_reprojection(motion[None], keypoints[:1], cams[:1], single) == {} and not single.lines


def test_persons_finished_on_threads_come_out_as_one_thread_makes_them(tiny_prior):
    """The sports2d demo's two persons lifted on the estimated floor's stand-in (z = 0 under the level default
    camera), then finished on one thread and on two: every array, every meta entry and every log line the same
    (each person's steps write that person's slices only)."""
    import re

    from platypose.lifting.finish.steps import finish_take
    from platypose.lifting.floor import plane_floor
    from platypose.lifting.settings import SamplerConfig, WindowSettings
    from platypose.lifting.tracks.stream import lift_tracks

    floor = plane_floor(0.0, 0.0, 1.0, 1.5, "given")  # 1.5 m under the default camera at the origin
    config, windows = SamplerConfig(samples=3, seed=0, floor=floor.plane), WindowSettings(max_gap=1.0)
    take = demo_take(config, windows)
    camera = take.cameras[0]
    lifted = lift_tracks(tiny_prior, [camera], take.keypoints, take.times, config, windows)
    outcomes = []
    for workers in (1, 2):
        hypotheses = lifted.hypotheses.copy()
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # frames where a person is absent: all NaN
            median = np.nanmedian(hypotheses, axis=1)
        log = JobLog()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            finished = finish_take(
                take, hypotheses=hypotheses, median=median, fps=30.0, floor=floor, log=log, workers=workers
            )
        assert not [w for w in caught if issubclass(w.category, RuntimeWarning)]  # none let through by the threads
        untimed = (re.sub(r"^\[ *[0-9.]+ s\] ", "", line) for line in log.lines)  # the log's clock is not the result
        said = [re.sub(r"made a body in [0-9.]+ s", "made a body", line) for line in untimed]
        outcomes.append((hypotheses, median, finished.rigid_bones, finished.plausibility, said))
    (h1, m1, r1, p1, s1), (h2, m2, r2, p2, s2) = outcomes
    assert np.array_equal(h1, h2, equal_nan=True) and np.array_equal(m1, m2, equal_nan=True)
    assert r1 == r2 and p1 == p2 and s1 == s2
    assert sum("depth steadied" in line for line in s1) == 2 and sum("made a body" in line for line in s1) == 2


def test_usable_cores_where_the_system_has_no_affinity(monkeypatch):
    """Linux says which cores the process may use; macOS and Windows have no such call: all cores then."""
    import os

    from platypose.lifting.finish.steps import usable_cores

    assert usable_cores() == len(os.sched_getaffinity(0)) >= 1
    monkeypatch.delattr(os, "sched_getaffinity")
    monkeypatch.setattr(os, "cpu_count", lambda: 12)
    assert usable_cores() == 12
