"""The runs ``train`` and ``eval`` ask for, called as library functions without the command line
(lifting/offline/train_run.py, lifting/offline/eval_run.py): the commands only parse their options and print."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from platypose.lifting.errors import InputError
from platypose.lifting.offline.eval_run import EvalRun, run_evaluation
from platypose.lifting.offline.motion_pack import read_pack
from platypose.lifting.offline.train_run import TrainRun, run_training
from platypose.lifting.settings import PriorSettings, SamplerConfig


def test_a_pack_is_written_from_the_data_less_the_unseen_sets(data_dir, tmp_path):
    (tmp_path / "deepmimic").symlink_to(data_dir / "motion/deepmimic")
    unseen = tmp_path / "unseen.json"
    unseen.write_text(json.dumps({"walks": ["deepmimic/humanoid3d_walk.txt"]}))
    said: list[str] = []
    run = TrainRun(data=(tmp_path / "deepmimic",), pack=tmp_path / "pack.npz", hold_out=unseen)
    run_training(run, say=said.append)
    names = {m.name for m in read_pack(tmp_path / "pack.npz")}
    assert len(names) == len(list((data_dir / "motion/deepmimic").glob("*.txt"))) - 1
    assert "humanoid3d_walk" not in names and len(said) == 1 and said[0].startswith(f"packed {len(names)} clips")


def test_a_run_asks_for_a_checkpoint_or_a_pack(data_dir, tmp_path):
    with pytest.raises(InputError, match="not both"):
        run_training(TrainRun(data=(data_dir / "motion/deepmimic",)))


def test_an_evaluation_says_its_table_and_writes_it(prior_file, data_dir, tmp_path):
    said: list[str] = []
    run = EvalRun(
        motion=(data_dir / "motion/deepmimic/humanoid3d_walk.txt",), sets=None, cams=None, views=1, frames=(1, 8),
        samples=(4,), noise_px=0.0, windows=1, heldout=False, baseline=False, rigid=True, gap_s=0.0,
        json_out=tmp_path / "eval.json",
    )  # fmt: skip
    run_evaluation(run, PriorSettings(Path(prior_file)), SamplerConfig(), say=said.append)
    rows = json.loads((tmp_path / "eval.json").read_text())["rows"]
    assert [r["frames"] for r in rows] == [1, 8] and said[0].startswith("1 clips, prior ") and "cameras" in said[0]
