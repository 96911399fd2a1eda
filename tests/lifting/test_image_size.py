"""A calibration's image size against the video's: the codec's padding to 16 is the same image (a note), any other
small difference a warning, a large one an error naming the file."""

import pytest

from platypose.lifting.calibration import load_calibration
from platypose.lifting.errors import InputError
from platypose.lifting.job_log import JobLog
from platypose.media import video_info
from platypose.pipeline import check_image_size


def test_the_demo_calibration_states_its_videos_coded_size_and_is_not_warned_about(data_dir):
    """The bundled Pose2Sim take: calibrated 1088 px wide (the H.264 coded width), its MP4s decode 1080 wide."""
    take = data_dir / "video" / "pose2sim-balancing"
    camera = load_calibration(take / "calib_pose2sim.toml").cameras[0]
    video = take / "cam01.mp4"
    size = video_info(video).image_size
    assert camera.size == (1920, 1088) and size == (1920, 1080)
    log = JobLog()
    check_image_size(camera, size, str(video), log)
    assert log.warnings == [] and log.notes == [
        f"calibration says 1088x1920 px for camera cam_01, {video} is 1080x1920: "
        "the codec's padding to a multiple of 16, the same pixels"
    ]


@pytest.mark.parametrize("width", [1070, 1090])  # within 2 % but not 1080 padded to 16: pixels may differ
def test_another_small_difference_is_a_warning(data_dir, width):
    take = data_dir / "video" / "pose2sim-balancing"
    camera = load_calibration(take / "calib_pose2sim.toml").cameras[0]
    log = JobLog()
    check_image_size(camera, (1920, width), "v.mp4", log)
    assert (
        log.notes == []
        and len(log.warnings) == 1
        and f"v.mp4 is {width}x1920; pixels used as they are" in log.warnings[0]
    )
    with pytest.raises(InputError, match="v.mp4: calibration mismatch: calibration says 1088x1920 px"):
        check_image_size(camera, (960, 540), "v.mp4", JobLog())
