"""A file of unseen sets is read only as a regular JSON file of relative, non-empty patterns; else one line."""

from __future__ import annotations

import os
import shutil
import signal
from pathlib import Path

import pytest

from platypose.lifting.errors import InputError
from platypose.lifting.offline.unseen_sets import load_sets

WALK = Path(__file__).resolve().parents[3] / "data" / "motion" / "deepmimic" / "humanoid3d_walk.txt"


@pytest.fixture
def folder(tmp_path) -> Path:
    """A folder holding one real motion file beside the sets file to come."""
    (tmp_path / "walks").mkdir()
    shutil.copy(WALK, tmp_path / "walks" / WALK.name)
    return tmp_path


def test_a_set_of_relative_patterns_is_read(folder):
    spec = folder / "unseen.json"
    spec.write_text('{"walks": ["walks/*.txt"]}')
    assert load_sets(spec) == {"walks": [(folder / "walks" / WALK.name).resolve()]}


@pytest.mark.parametrize(
    "patterns, words",
    [
        ('["/etc/*"]', "set 'a': pattern '/etc/\\*' is absolute"),
        ('["walks/*", ""]', "set 'a': pattern '' is empty"),
        ('["  "]', "set 'a': pattern '  ' is empty"),
    ],
    ids=["absolute", "empty", "blank"],
)
def test_an_absolute_or_empty_pattern_is_one_line(folder, patterns: str, words: str):
    spec = folder / "unseen.json"
    spec.write_text('{"a": %s}' % patterns)
    with pytest.raises(InputError, match=rf"unseen.json: {words}"):
        load_sets(spec)


def test_sets_nested_100000_deep_are_one_line(folder):
    spec = folder / "unseen.json"
    spec.write_text('{"a": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(InputError, match=r"unseen.json: not a readable JSON file of unseen sets \(nested too deep\)$"):
        load_sets(spec)


def test_a_fifo_is_refused_at_once(folder):
    fifo = folder / "unseen.json"
    os.mkfifo(fifo)

    def hang(*_):
        raise TimeoutError("load_sets waited on the FIFO")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(10)
    try:
        with pytest.raises(InputError, match=r"unseen.json: is a FIFO \(named pipe\), a regular unseen-sets file"):
            load_sets(fifo)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
