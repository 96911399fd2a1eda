"""json_value: a JSON file's value, or why there is none in words (never RecursionError)."""

from __future__ import annotations

import pytest

from platypose.lifting.files.reads import json_value


def test_json_value_reads_json():
    assert json_value(b'{"a": [1, 2.5, "x"]}') == {"a": [1, 2.5, "x"]}


@pytest.mark.parametrize(
    "text, words",
    [("[" * 100_000 + "]" * 100_000, "nested too deep"), ("{", "not JSON: "), (b"\xff\xfe{", "not JSON: ")],
    ids=["nested-100000", "syntax", "not-utf8"],
)
def test_json_value_says_why_there_is_none(text, words: str):
    with pytest.raises(ValueError, match=words):
        json_value(text)
