"""platypose.lift and load_result take natural Python values and refuse the rest with an InputError naming the
argument, before any work."""

from __future__ import annotations

import pytest

import platypose
from platypose.data import VIDEO_DIR

TAKE = VIDEO_DIR / "pose2sim-balancing"
VIEWS = sorted((TAKE / "openpose-body25b").iterdir())
ONE_VIEW = VIEWS[0]
CAMS = TAKE / "calib_pose2sim.toml"


@pytest.mark.parametrize(
    "arguments, option, words",
    [
        ({"samples": 2.5}, "samples", "samples must be an integer"),
        ({"samples": "5"}, "samples", "samples must be an integer"),
        ({"samples": True}, "samples", "samples must be an integer"),
        ({"seed": -1}, "seed", "seed must be in"),
        ({"temperature": "1"}, "temperature", "temperature must be a finite number"),
        ({"size_prior": 1}, "size_prior", "size_prior must be True or False"),
        ({"stride": 0}, "stride", "stride must be an integer >= 1"),
        ({"stride": -1}, "stride", "stride must be an integer >= 1"),
        ({"stride": 1.5}, "stride", "stride must be an integer >= 1"),
        ({"threads": 0}, "threads", "threads must be an integer >= 1"),
        ({"image_size": "1920x1080"}, "image_size", "image_size must be (height, width)"),
        ({"image_size": (1080,)}, "image_size", "image_size must be (height, width)"),
        ({"fps": "60"}, "fps", "fps must be a positive number"),
        ({"fps": 0}, "fps", "fps must be a positive number"),
        ({"fps": float("nan")}, "fps", "fps must be a positive number"),
        ({"persons": 0}, "persons", "persons must be"),
        ({"persons": "tallest"}, "persons", "persons must be"),
        ({"persons": 1.5}, "persons", "persons must be a string"),
        ({"root": "float"}, "root", "root must be one of"),
        ({"floor": 3}, "floor", "floor must be a string"),
        ({"floor": (0, 0, 1)}, "floor", "floor .0.0,0.0,1.0.: not understood"),
        ({"sync": 5}, "sync", "sync must be auto, none"),
        ({"windows": {"window": 32}}, "windows", "windows must be a WindowSettings"),
        ({"sampler": {"samples": 3}}, "sampler", "sampler must be a SamplerConfig"),
        ({"samplse": 3}, "samplse", "unknown argument(s) samplse"),
        ({"root_trajectory": 7}, "root_trajectory", "root_trajectory must be a path"),
        ({"detector": 7}, "detector", "detector must be a path"),
        ({"prior": 7}, "prior", "prior must be a path"),
        ({"say": "print"}, "say", "say must be a function"),
    ],
)
def test_a_bad_argument_is_an_input_error_naming_it(arguments, option, words):
    with pytest.raises(platypose.InputError, match=words.replace("(", r"\(").replace(")", r"\)")) as caught:
        platypose.lift(ONE_VIEW, **arguments)
    assert caught.value.option == option and "\n" not in str(caught.value)


@pytest.mark.parametrize(
    "views, cams, option",
    [(None, None, "views"), ([], None, "views"), (7, None, "views"), ([ONE_VIEW, 3], None, "views")]
    + [(ONE_VIEW, 123, "cams"), (ONE_VIEW, [1, 2], "cams"), (ONE_VIEW, [], "cams")],
)
def test_bad_views_or_cams_are_input_errors_naming_them(views, cams, option):
    with pytest.raises(platypose.InputError) as caught:
        platypose.lift(views, cams)
    assert caught.value.option == option and option in str(caught.value)


@pytest.mark.parametrize("path", [None, 5, ""])
def test_load_result_of_a_non_path_is_an_input_error(path):
    with pytest.raises(platypose.InputError, match="path must be a path") as caught:
        platypose.load_result(path)
    assert caught.value.option == "path"


def test_natural_values_are_taken_as_the_command_spells_them():
    from platypose.lifting.settings import TakeSettings

    take = TakeSettings(persons=1, floor=None, sync=None)
    assert (take.persons, take.floor, take.sync) == ("largest:1", "none", "none")
    assert TakeSettings(floor=(0, 0, 1, 0)).floor == "0.0,0.0,1.0,0.0"
    assert TakeSettings(sync={"cam01": 0}).sync == {"cam01": 0}
    assert TakeSettings(root_trajectory="p.csv").root_trajectory.name == "p.csv"


def test_natural_values_lift(tiny_default_prior):
    """persons=1, floor=None, sync=None, a float fps and an int image size, numpy integers: all taken."""
    import numpy as np

    result = platypose.lift(
        VIEWS[:2], CAMS, persons=1, floor=None, sync=None, samples=np.int64(2), seed=np.int32(1), stride=1
    )
    assert result.hypotheses.shape[:2] == (1, 2)
    assert result.meta["floor"] is None and result.meta["sync"]["mode"] == "none"
    assert result.meta["arguments"]["persons"] == "largest:1" and result.meta["arguments"]["floor"] == "none"


@pytest.fixture
def tiny_default_prior(monkeypatch, prior_file):
    """The tiny prior in place of the shipped one."""
    from pathlib import Path

    import platypose.lifting.prior.model as prior_module

    monkeypatch.setattr(prior_module, "DEFAULT_PRIOR", Path(prior_file))
    return prior_file


def test_prior_load_checks_a_pieces_index_before_reading(tmp_path):
    index = tmp_path / "prior.pt"
    piece = {"file": "prior.pt.0123456789ab.001", "bytes": 10, "sha256": "0" * 64}
    (tmp_path / piece["file"]).write_bytes(b"0123456789")
    text = '{"format": "platypose-prior-pieces", "bytes": 10, "sha256": "%s", "pieces": %s}'
    index.write_text(text % ("0" * 64, str([piece] * 6000).replace("'", '"')))
    with pytest.raises(platypose.InputError, match=r"prior.pt: the index's piece sizes do not sum to its 10 bytes$"):
        platypose.Prior.load(index)
