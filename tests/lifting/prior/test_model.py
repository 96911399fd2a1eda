"""A prior larger than a piece is written as pieces beside a small index; loading joins and checks them."""

from __future__ import annotations

import json
import os
import pathlib

import numpy as np
import pytest
import torch

from platypose.lifting.errors import InputError
from platypose.lifting.prior import pieces as pieces_module
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
    with pytest.raises(InputError, match=r"prior.pt: damaged index of prior pieces \(not JSON: "):
        load_prior(path)


def edit_index(path, change) -> None:
    index = json.loads(path.read_text())
    change(index)
    path.write_text(json.dumps(index))


@pytest.fixture
def nothing_read(monkeypatch):
    """Fail the test if a piece is read: the index must be refused from what it states and ``stat`` alone."""

    def refuse(*args, **kwargs):
        raise AssertionError("a piece was read before the index was checked")

    monkeypatch.setattr(pieces_module, "read_regular", refuse)
    monkeypatch.setattr(pathlib.Path, "read_bytes", refuse)


def test_an_index_naming_one_piece_many_times_is_refused_unread(pieces, nothing_read):
    path, _, _ = pieces
    edit_index(path, lambda ix: ix.update(pieces=[ix["pieces"][0]] * 6000))
    with pytest.raises(InputError, match=r"prior.pt: the index's piece sizes do not sum to its \d+,\d+ bytes$"):
        load_prior(path)


def test_a_piece_named_twice_is_refused_unread(pieces, nothing_read):
    path, _, _ = pieces
    edit_index(path, lambda ix: ix.update(pieces=[ix["pieces"][0]] * 2, bytes=2 * ix["pieces"][0]["bytes"]))
    with pytest.raises(InputError, match=r"prior.pt: piece 2 of 2 \(prior.pt.\w+.001\) is named twice$"):
        load_prior(path)


def test_an_index_over_the_size_bound_is_refused_unread(pieces, nothing_read):
    path, _, _ = pieces
    huge = 5 * 2**30
    edit_index(path, lambda ix: ix.update(bytes=huge, pieces=[dict(ix["pieces"][0], bytes=huge)]))
    with pytest.raises(InputError, match=r"prior.pt: the index claims 5,368,709,120 bytes, over the 4,294,967,296"):
        load_prior(path)


def test_a_piece_of_another_size_on_disk_is_refused_unread(pieces, nothing_read):
    path, _, _ = pieces
    os.truncate(piece_files(path)[1], 2**31)  # sparse: 2 GiB named, nothing written
    with pytest.raises(InputError, match=r"piece 2 of \d+ .* has 2147483648 bytes, the index says \d+ \(truncated"):
        load_prior(path)


def test_a_piece_linked_out_of_the_index_folder_is_refused(pieces, tmp_path):
    path, _, _ = pieces
    piece = piece_files(path)[0]
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / piece.name).write_bytes(piece.read_bytes())  # the very bytes: only where it lies is wrong
    piece.unlink()
    piece.symlink_to(elsewhere / piece.name)
    with pytest.raises(InputError, match=r"piece 1 of \d+ .* is a link leading out of the index's folder$"):
        load_prior(path)


def test_a_link_to_a_piece_in_the_index_folder_is_read(pieces):
    path, _, checksum = pieces
    piece = piece_files(path)[0]
    piece.rename(path.parent / "kept")
    piece.symlink_to("kept")
    assert load_prior(path)[0].checksum == checksum


def test_a_piece_that_is_a_folder_is_refused(pieces):
    path, _, _ = pieces
    piece = piece_files(path)[2]
    piece.unlink()
    piece.mkdir()
    with pytest.raises(InputError, match=r"piece 3 of \d+ .* is a folder, not a piece$"):
        load_prior(path)


@pytest.mark.parametrize(
    "text, problem",
    [
        (
            '{"format": "platypose-prior-pieces", "bytes": 1e400, "sha256": "%s", "pieces": [%s]}'
            % ("0" * 64, '{"file": "prior.pt.0123456789ab.001", "bytes": 1, "sha256": "%s"}' % ("0" * 64)),
            "it must give",
        ),
        ('{"format": "platypose-prior-pieces", "x": ' + "[" * 100_000 + "]" * 100_000 + "}", "nested too deep"),
        ('{"format": "platypose-prior-pieces", "bytes": 10, "sha256": "x", "pieces": [{"file": 1}]}', "it must give"),
    ],
    ids=["bytes-1e400", "nested-100000", "wrong-types"],
)
def test_a_crafted_index_is_one_line(tmp_path, text: str, problem: str):
    path = tmp_path / "prior.pt"
    path.write_text(text)
    with pytest.raises(InputError, match=rf"prior.pt: damaged index of prior pieces \({problem}"):
        load_prior(path)


def test_a_rewrite_removes_only_the_pieces_the_index_listed(pieces):
    path, bundle, _ = pieces
    old = piece_files(path)
    kept = [path.parent / "prior.pt.notes.001", path.parent / "prior.pt.0123456789ab.001", path.parent / "other.001"]
    for file in kept:
        file.write_text("the user's")
    save_prior(path, bundle, extra={"iteration": 9}, piece_bytes=PIECE)
    assert not any(f.exists() for f in old) and all(f.read_text() == "the user's" for f in kept)
    new = piece_files(path)
    save_prior(path, bundle, extra={"iteration": 10}, piece_bytes=10**9)  # whole: the pieces go, the rest stays
    assert not any(f.exists() for f in new) and all(f.read_text() == "the user's" for f in kept)


def test_a_rewrite_keeps_a_listed_file_of_another_form(pieces):
    path, bundle, _ = pieces
    user = path.parent / "notes.txt"
    user.write_text("the user's")
    edit_index(path, lambda ix: ix["pieces"].append({"file": "notes.txt", "bytes": 10, "sha256": "0" * 64}))
    save_prior(path, bundle, piece_bytes=10**9)
    assert user.read_text() == "the user's"
