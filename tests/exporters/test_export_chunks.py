"""Exporters read results a chunk of frames at a time: small chunks and on-disk arrays write the same files."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from export_helpers import read_entities, two_person_result

from platypose.exporters import export, frames
from platypose.exporters.frames import FrameArray, Lead
from platypose.exporters.npz import read_npz
from platypose.exporters.result import LiftResult

FORMATS = ["npz", "csv", "csv-long", "bvh", "rrd"]


def on_disk(result: LiftResult, folder) -> LiftResult:
    """``result`` with hypotheses, median and energy in FrameArray files under ``folder``."""
    fields = {}
    for name in ("hypotheses", "median", "energy"):
        values = getattr(result, name)
        fields[name] = FrameArray.create(folder / f"{name}.npy", values.shape, np.float32)
        fields[name][...] = values
    return dataclasses.replace(result, **fields)


@pytest.fixture(scope="module")
def whole(data_dir, tmp_path_factory):
    """The two-person result exported in one chunk (30 frames < CHUNK_FRAMES): folder and result."""
    result = two_person_result(data_dir)
    folder = tmp_path_factory.mktemp("whole")
    export(result, folder, "clip", FORMATS, bvh="all", rrd_video="none")
    return folder, result


def test_frame_array_reads_and_writes_like_numpy(tmp_path):
    values = np.arange(2 * 3 * 5 * 4, dtype=np.float32).reshape(2, 3, 5, 4)
    array = FrameArray.create(tmp_path / "a.npy", values.shape, np.float32)
    assert array.shape == values.shape and not array[...].any()
    array[[1, 0], :, 1:4] = values[[1, 0], :, 1:4]
    assert np.array_equal(np.load(tmp_path / "a.npy")[:, :, 1:4], values[:, :, 1:4])
    assert np.array_equal(FrameArray(tmp_path / "a.npy")[1, 2, [3, 1]], values[1, 2, [3, 1]])
    assert np.array_equal(Lead(array, 1, 2)[1:3], values[1, 2, 1:3]) and Lead(array, 1).shape == (3, 5, 4)


def test_small_chunks_from_disk_write_the_same_files(whole, tmp_path, monkeypatch):
    folder, result = whole
    monkeypatch.setattr(frames, "CHUNK_FRAMES", 7)  # 30 frames: 5 chunks, the second person's first 5 frames absent
    chunked = on_disk(result, tmp_path)
    assert isinstance(chunked.hypotheses, FrameArray) and np.array_equal(chunked.present(), result.present())
    out = tmp_path / "out"
    written = export(chunked, out, "clip", FORMATS, bvh="all", rrd_video="none")
    assert len(written) == 19
    for path in written:
        if path.suffix in (".csv", ".bvh"):
            assert path.read_bytes() == (folder / path.name).read_bytes(), path.name
    back, expected = read_npz(out / "clip.npz"), read_npz(folder / "clip.npz")
    for name in ("hypotheses", "median", "keypoints2d", "energy", "frame_times"):
        assert np.array_equal(getattr(back, name), getattr(expected, name), equal_nan=True), name
    assert np.array_equal(back.hypotheses, result.hypotheses, equal_nan=True)
    fits, expected_fits = back.meta.pop("bvh_fit_error"), expected.meta.pop("bvh_fit_error")
    assert back.meta == expected.meta and fits.keys() == expected_fits.keys() == {"p0", "p7"}
    for person, fit in fits.items():
        assert fit["median"] == pytest.approx(expected_fits[person]["median"], rel=1e-12)
    entities, expected_entities = read_entities(out / "clip.rrd"), read_entities(folder / "clip.rrd")
    assert entities.keys() == expected_entities.keys() and "/world/people/p7/hypotheses" in entities
    for entity, columns in expected_entities.items():
        if entity == "/__properties":  # the recording's start time
            continue
        for column, values in columns.items():
            got = entities[entity][column]
            if column.startswith("static:"):  # each chunk declares its entity's static fields again
                assert all(v == values[0] for v in got + values), (entity, column)
            else:
                assert got == values, (entity, column)
