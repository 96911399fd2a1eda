"""The GPU recipe's code path on the CPU: training data packed into one file, bfloat16 autocast, --device auto,
and the unseen sets held out of training."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

TINY = ["--layers", "1", "--width", "32", "--heads", "2", "--ff-width", "32", "--max-frames", "8"]
STEPS = ["--iterations", "3", "--batch-size", "4", "--checkpoint-every", "2", "--validate-every", "1"]


@pytest.fixture
def clips(data_dir):
    folder = data_dir / "motion/deepmimic"
    return [folder / "humanoid3d_walk.txt", folder / "humanoid3d_run.txt", data_dir / "motion/cmu-asf-amc/test.amc"]


def test_a_pack_holds_the_clips_as_training_prepares_them(run_cli, clips, tmp_path):
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.motion_pack import read_pack
    from platypose.lifting.offline.training import prepare_clips

    pack = tmp_path / "pack.npz"
    code, _, err = run_cli("train", *clips, "--pack", pack)
    assert code == 0, err
    assert "packed 3 clips" in err and not (tmp_path / "p.pt").exists()
    packed, direct = prepare_clips(read_pack(pack), 30.0), prepare_clips(load_motion_paths(clips), 30.0)
    assert [(c.name, c.source, c.licence, c.original_fps) for c in packed] == [
        (c.name, c.source, c.licence, c.original_fps) for c in direct
    ]
    assert direct[2].original_fps != 30.0  # the manifest keeps each clip's own rate, not the pack's
    for a, b in zip(packed, direct):
        assert a.joints.shape == b.joints.shape and np.abs(a.joints - b.joints).max() <= 0.0005 + 1e-9


def test_the_recipe_trains_from_a_pack_in_bfloat16_on_auto_device(run_cli, clips, tmp_path):
    from platypose.lifting.prior.model import load_prior

    pack = tmp_path / "pack.npz"
    assert run_cli("train", *clips, "--pack", pack)[0] == 0
    runs = {}
    for precision in ("bfloat16", "float32"):
        out, log = tmp_path / f"{precision}.pt", tmp_path / f"{precision}.jsonl"
        code, _, err = run_cli(
            "train", pack, "--out", out, "--device", "auto", "--precision", precision, *TINY, *STEPS,
            "--log-file", log, "--quiet",
        )  # fmt: skip
        assert code == 0, err
        bundle, extra = load_prior(out)
        entries = [json.loads(line) for line in log.read_text().splitlines()]
        assert [e["iteration"] for e in entries] == [1, 2, 3] and all(np.isfinite(e["val_loss"]) for e in entries)
        assert extra == {} and bundle.manifest["iterations"] == 3
        assert sorted(c["name"] for c in bundle.manifest["clips"]) == sorted(c.stem for c in clips)
        runs[precision] = bundle.model.state_dict()
    # autocast really ran: the same seed in bfloat16 ends elsewhere than in float32
    differ = [name for name, value in runs["float32"].items() if not torch.equal(value, runs["bfloat16"][name])]
    assert differ


def test_cuda_without_a_gpu_is_one_line(run_cli, clips, tmp_path):
    if torch.cuda.is_available():
        pytest.skip("this machine has a GPU")
    code, _, err = run_cli("train", *clips, "--out", tmp_path / "p.pt", "--device", "cuda", *TINY, *STEPS)
    assert code == 2 and "sees no CUDA GPU" in err and not (tmp_path / "p.pt").exists()


def test_hold_out_leaves_every_unseen_file_out(run_cli, data_dir, tmp_path):
    from platypose.lifting.offline.motion_pack import read_pack

    spec = tmp_path / "unseen.json"
    spec.write_text(json.dumps({"broad": ["deepmimic/humanoid3d_walk*", "mocapbank"]}))
    for folder in ("deepmimic", "mocapbank"):
        (tmp_path / folder).symlink_to(data_dir / "motion" / folder)
    pack = tmp_path / "pack.npz"
    code, _, err = run_cli("train", tmp_path / "deepmimic", tmp_path / "mocapbank", "--hold-out", spec, "--pack", pack)
    assert code == 0, err
    names = [m.name for m in read_pack(pack)]
    assert "humanoid3d_run" in names and "humanoid3d_walk" not in names
    assert not any("mocapbank" in m.name for m in read_pack(pack)) and len(names) == 14


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"x": ["nothing*"]}', "set 'x': pattern 'nothing*' matches no motion file"),
        ('{"x": []}', "must map each set's name to a non-empty list of glob patterns"),
        ("{", "not a readable JSON file of unseen sets"),
    ],
)
def test_a_bad_unseen_file_is_one_line(run_cli, clips, tmp_path, text, message):
    spec = tmp_path / "unseen.json"
    spec.write_text(text)
    code, _, err = run_cli("train", *clips, "--hold-out", spec, "--pack", tmp_path / "pack.npz")
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "pack.npz").exists()
