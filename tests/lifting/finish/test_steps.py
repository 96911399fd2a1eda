"""The per-view reprojection report of `platypose lift`: a view far off its keypoints is named in a warning."""

import numpy as np

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
