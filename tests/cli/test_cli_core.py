"""The console entry: version, help, train/eval/prior-info, and one-line errors with exit code 2."""

import json
import subprocess
import sys

import pytest
import torch


def test_version_and_help_in_a_fresh_process():
    result = subprocess.run([sys.executable, "-m", "platypose", "--version"], capture_output=True, text=True)
    assert result.returncode == 0 and result.stdout.startswith("platypose ")
    result = subprocess.run([sys.executable, "-m", "platypose", "--help"], capture_output=True, text=True)
    assert result.returncode == 0
    for command in ("lift", "train", "eval", "detect", "calib"):
        assert command in result.stdout


def _one_line_error(code, err):
    assert code == 2
    lines = [line for line in err.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), err
    assert "Traceback" not in err


def test_eval_prints_the_table_and_writes_json(run_cli, prior_file, data_dir, tmp_path):
    out_json = tmp_path / "eval.json"
    code, out, err = run_cli(
        "eval",
        data_dir / "motion/deepmimic/humanoid3d_walk.txt",
        "--prior",
        prior_file,
        "--frames",
        "1,16",
        "--samples",
        "8",
        "--windows",
        "1",
        "--views",
        "4",
        "--json",
        out_json,
    )
    assert code == 0, err
    assert "minMPSPE" in out and "frame-by-frame" in out
    rows = json.loads(out_json.read_text())["rows"]
    assert [(r["method"], r["frames"]) for r in rows] == [("platypose", 1), ("platypose", 16), ("frame-by-frame", 16)]
    four_view = rows[1]["values"]
    assert four_view["minMPSPE"] < 10.0  # mm: 4 views, exact 2D
    assert 0 <= four_view["ECE"] <= 1
    assert four_view["ECE worst"] == four_view["ECE"]  # one clip


def test_prior_info_lists_licences(run_cli, prior_file):
    code, out, _ = run_cli("prior-info", prior_file)
    assert code == 0
    assert "Apache-2.0" in out and "humanoid3d_walk" in out


def test_train_writes_a_loadable_checkpoint(run_cli, data_dir, tmp_path):
    out = tmp_path / "p.pt"
    clip = data_dir / "motion/deepmimic/humanoid3d_walk.txt"
    common = (
        "--layers",
        "1",
        "--width",
        "32",
        "--heads",
        "2",
        "--ff-width",
        "32",
        "--max-frames",
        "8",
        "--batch-size",
        "4",
        "--quiet",
    )
    code, _, err = run_cli(
        "train",
        clip,
        data_dir / "motion/deepmimic/humanoid3d_run.txt",
        "--out",
        out,
        "--iterations",
        "6",
        "--checkpoint-every",
        "3",
        *common,
    )
    assert code == 0, err
    from platypose.lifting.prior.model import load_prior

    bundle, extra = load_prior(out)
    assert bundle.config.width == 32 and bundle.manifest["iterations"] == 6 and extra == {}
    assert {c["split"] for c in bundle.manifest["clips"]} == {"train", "validation"}


def test_an_interrupted_training_resumes_from_its_last_checkpoint(run_cli, data_dir, tmp_path):
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.training import train_prior
    from platypose.lifting.prior.model import PriorConfig, load_prior
    from platypose.lifting.settings import TrainConfig

    out, log = tmp_path / "p.pt", tmp_path / "log.jsonl"
    clips = [data_dir / "motion/deepmimic/humanoid3d_walk.txt", data_dir / "motion/deepmimic/humanoid3d_run.txt"]
    prior_config = PriorConfig(layers=1, width=32, heads=2, ff_width=32, max_frames=8)

    def stop_after_four(entry: dict) -> None:
        if entry["iteration"] == 4:
            raise KeyboardInterrupt  # the user's Ctrl-C, one step after the checkpoint at 3

    with pytest.raises(KeyboardInterrupt):
        train_prior(
            load_motion_paths(clips),
            str(out),
            prior_config,
            TrainConfig(iterations=8, batch_size=4, checkpoint_every=3, validate_every=1),
            log=stop_after_four,
        )
    bundle, extra = load_prior(out)  # the periodic checkpoint is complete and loadable
    assert bundle.manifest["iterations"] == 3 and extra["iteration"] == 3
    code, _, err = run_cli(
        "train",
        *clips,
        "--out",
        out,
        "--resume",
        "--iterations",
        "8",
        "--batch-size",
        "4",
        "--checkpoint-every",
        "3",
        "--log-file",
        log,
    )
    assert code == 0, err
    assert f"resuming {out} at iteration 3 of 8" in err
    bundle, extra = load_prior(out)
    assert bundle.manifest["iterations"] == 8 and extra == {} and bundle.config.width == 32
    logged = [json.loads(line)["iteration"] for line in log.read_text().splitlines()]
    assert logged == [8]  # validation losses are logged every 250 steps and at the end


@pytest.mark.parametrize(
    "args",
    [("--samples", "-5"), ("--robust", "cauchy"), ("--frames", "0"), ("--skip", "10")],
)
def test_bad_eval_arguments_give_one_line_errors(run_cli, prior_file, data_dir, args):
    code, _, err = run_cli("eval", data_dir / "motion/deepmimic/humanoid3d_walk.txt", "--prior", prior_file, *args)
    _one_line_error(code, err)


def test_a_checkpoint_that_is_not_ours_is_refused(run_cli, data_dir, tmp_path):
    foreign = tmp_path / "foreign.pt"
    torch.save({"weights": torch.zeros(3)}, foreign)
    garbage = tmp_path / "garbage.pt"
    garbage.write_bytes(b"not a checkpoint at all")
    for path in (foreign, garbage):
        code, _, err = run_cli("eval", data_dir / "motion/deepmimic/humanoid3d_walk.txt", "--prior", path)
        _one_line_error(code, err)
        assert str(path) in err


def test_a_resumed_training_ends_with_the_weights_of_an_uninterrupted_one(data_dir, tmp_path):
    import torch

    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.offline.training import train_prior
    from platypose.lifting.prior.model import PriorConfig, load_prior
    from platypose.lifting.settings import TrainConfig

    clips = load_motion_paths([data_dir / "motion/deepmimic/humanoid3d_walk.txt"])
    prior_config = PriorConfig(layers=1, width=32, heads=2, ff_width=32, max_frames=8)
    config = TrainConfig(iterations=6, batch_size=4, checkpoint_every=3, validate_every=1)
    whole = train_prior(clips, str(tmp_path / "whole.pt"), prior_config, config)

    def stop_after_four(entry: dict) -> None:
        if entry["iteration"] == 4:
            raise KeyboardInterrupt  # one step after the checkpoint at 3

    with pytest.raises(KeyboardInterrupt):
        train_prior(clips, str(tmp_path / "cut.pt"), prior_config, config, log=stop_after_four)
    _, extra = load_prior(tmp_path / "cut.pt")
    resumed = train_prior(clips, str(tmp_path / "cut.pt"), prior_config, config, resume=extra)
    for name, value in whole.model.state_dict().items():
        assert torch.equal(value, resumed.model.state_dict()[name]), name
