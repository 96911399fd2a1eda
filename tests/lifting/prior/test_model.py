"""A prior larger than a piece is written as pieces beside a small index; loading joins and checks them."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from platypose.lifting.errors import InputError
from platypose.lifting.prior.features import FEATURES_PER_FRAME, Normalizer
from platypose.lifting.prior.model import MotionPrior, PriorBundle, PriorConfig, load_prior, save_prior

PIECE = 20_000  # bytes: the small network below makes three or more pieces


@pytest.fixture
def pieces(tmp_path):
    torch.manual_seed(0)
    model = MotionPrior(PriorConfig(layers=1, width=32, heads=2, ff_width=64, max_frames=8))
    normalizer = Normalizer(np.zeros(FEATURES_PER_FRAME), np.ones(FEATURES_PER_FRAME))
    bundle = PriorBundle(model, normalizer, {"clips": [], "licences": ["MIT"]})
    path = tmp_path / "prior.pt"
    checksum = save_prior(path, bundle, extra={"iteration": 7}, piece_bytes=PIECE)
    return path, bundle, checksum


def piece_files(path):
    return [path.parent / p["file"] for p in json.loads(path.read_text())["pieces"]]


def test_pieces_round_trip_to_the_same_weights_and_checksum(pieces):
    path, bundle, checksum = pieces
    files = piece_files(path)
    assert len(files) >= 3 and all(f.stat().st_size <= PIECE for f in files)
    assert path.stat().st_size < 2000  # the index only
    loaded, extra = load_prior(path)
    assert loaded.checksum == checksum and extra == {"iteration": 7}
    for name, value in bundle.model.state_dict().items():
        assert torch.equal(value, loaded.model.state_dict()[name]), name
    whole = save_prior(path, loaded, extra=extra, piece_bytes=10**9)  # rewritten whole: the old pieces go
    assert whole == checksum and not any(f.exists() for f in files) and load_prior(path)[0].checksum == checksum


def test_a_rewrite_in_pieces_replaces_the_earlier_pieces(pieces):
    path, bundle, _ = pieces
    old = piece_files(path)
    save_prior(path, bundle, extra={"iteration": 8}, piece_bytes=PIECE)
    assert not any(f.exists() for f in old) and load_prior(path)[1] == {"iteration": 8}


def test_a_missing_piece_is_named(pieces):
    path, _, _ = pieces
    piece_files(path)[1].unlink()
    with pytest.raises(InputError, match=r"prior.pt: piece 2 of \d+ \(prior.pt.\w+.002\) is missing$"):
        load_prior(path)


def test_a_truncated_piece_is_named(pieces):
    path, _, _ = pieces
    last = piece_files(path)[-1]
    last.write_bytes(last.read_bytes()[:-10])
    with pytest.raises(InputError, match=r"piece (\d+) of \1 .* has \d+ bytes, the index says \d+ \(truncated"):
        load_prior(path)


def test_reordered_pieces_are_named(pieces):
    path, _, _ = pieces
    first, second = piece_files(path)[:2]
    a, b = first.read_bytes(), second.read_bytes()
    first.write_bytes(b)
    second.write_bytes(a)
    with pytest.raises(InputError, match=r"piece 1 of \d+ .* is not the piece the index names \(pieces reordered"):
        load_prior(path)


def test_a_damaged_index_is_one_line(pieces):
    path, _, _ = pieces
    path.write_text(path.read_text()[:60])
    with pytest.raises(InputError, match=r"prior.pt: damaged index of prior pieces$"):
        load_prior(path)
