"""DetectOptions (lifting/settings/detection.py): the detection options of ``detect``, ``lift`` and the API defined
once, and the one view reader (detectors/view_reader.py) reading a real take's keypoints with them."""

from __future__ import annotations

import dataclasses

import pytest

from platypose.data import VIDEO_DIR
from platypose.detectors.view_reader import ViewReader
from platypose.lifting.errors import InputError
from platypose.lifting.settings import DetectOptions

OPENPOSE = VIDEO_DIR / "pose2sim-balancing" / "openpose-body25b" / "cam01_json"


def test_every_field_has_help_and_the_defaults_build():
    assert all(f.metadata["help"] for f in dataclasses.fields(DetectOptions))
    assert DetectOptions() == DetectOptions() and DetectOptions().stride == 1


@pytest.mark.parametrize(
    "values, name, words",
    [
        ({"stride": 0}, "stride", "stride must be an integer >= 1, got 0"),
        ({"max_frames": 0}, "max_frames", "max_frames must be an integer >= 1, got 0"),
        ({"threads": 0}, "threads", "threads must be an integer >= 1, got 0"),
        ({"fps": -1.0}, "fps", "fps must be a positive number, got -1.0"),
        ({"image_size": (1080, 0)}, "image_size", "image_size must be (height, width) in pixels"),
        ({"detector": 7}, "detector", "detector must be a path, got 7"),
        ({"cache": 1}, "cache", "cache must be True or False"),
    ],
)
def test_a_bad_value_is_refused_naming_its_field(values, name, words):
    with pytest.raises(InputError) as caught:
        DetectOptions(**values)
    assert caught.value.option == name and words in str(caught.value)


def test_lift_and_detect_take_their_options_from_the_one_field():
    """``lift`` has the short help, ``detect`` the full one, both the field's default and minimum."""
    import inspect

    from platypose.cli.commands_detect import detect
    from platypose.cli.commands_lift import lift

    lift_options, detect_options = (inspect.signature(c).parameters for c in (lift, detect))
    for name in ("detector", "detector_format", "person_detector", "stride", "fps", "image_size"):
        field = DetectOptions.__dataclass_fields__[name]
        in_lift, in_detect = lift_options[name].default, detect_options[name].default
        assert in_lift.help == (field.metadata["short"] or field.metadata["help"]) and in_lift.help
        assert in_detect.help == field.metadata["help"] and in_lift.default == in_detect.default == field.default
    assert lift_options["stride"].default.min == detect_options["stride"].default.min == 1


def test_the_view_reader_reads_keypoints_at_the_given_rate_and_size():
    view = ViewReader(DetectOptions(fps=60.0, image_size=(1088, 1920)))(OPENPOSE)
    assert view.frames is None and view.how == "read"
    assert view.tracks.image_size == (1088, 1920) and view.tracks.num_frames > 10
    assert abs(float(view.tracks.frame_times[1] - view.tracks.frame_times[0]) - 1 / 60) < 1e-6
