"""``train`` refuses bad options and stops on a non-finite loss; a prior with non-finite weights is refused when
loaded (also by prior-info); sampler numbers (--seed, --samples, weights) are bounded. The audit cases (marker
``audit``, run with ``pytest -m audit``) give the shipped prior with NaN weights to ``prior-info`` and out-of-range
--seed and --samples to ``lift`` (:mod:`audit_support`)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from audit_support import REPO, Case, Run, check_case, lift_args, openpose_copy, registry

from platypose.lifting.errors import InputError
from platypose.lifting.motion import Motion
from platypose.lifting.offline.training import TrainingDiverged, train_prior
from platypose.lifting.prior.model import PriorConfig, load_prior, save_prior
from platypose.lifting.settings import TrainConfig

WALK = "motion/deepmimic/humanoid3d_walk.txt"


def one_line_error(code: int, err: str, *needles: str) -> None:
    lines = [line for line in err.strip().splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error:"), err
    for needle in needles:
        assert needle in lines[0], err


@pytest.mark.parametrize(
    "options, needle",
    [
        (["--max-frames", "0"], "train: max_frames must be at least 1, got 0"),
        (["--fps", "0"], "train: fps must be a positive number, got 0.0"),
        (["--fps", "inf"], "fps must be a positive number"),
        (["--width", "10", "--heads", "3"], "train: width 10 must be even and a multiple of heads (3)"),
        (["--learning-rate", "nan"], "--learning-rate must be a finite number, got nan"),
        (["--iterations", "0"], "--iterations must be at least 1"),
        (["--learning-rate", "2"], "--learning-rate must be in (0, 1)"),
        (["--checkpoint-every", "0"], "--checkpoint-every must be at least 1"),
        (["--bone-scale", "2"], "--bone-scale must be in [0, 1)"),
        (["--max-frames", "100000"], "max_frames must be at most 4096"),
        (["--threads", "-1"], "--threads must be 0"),
    ],
)
def test_bad_train_options_are_one_line(run_cli, data_dir, tmp_path, options, needle):
    code, _, err = run_cli("train", data_dir / WALK, "--out", tmp_path / "p.pt", *options)
    one_line_error(code, err, needle)
    assert not (tmp_path / "p.pt").exists()


@pytest.mark.parametrize("kind", ["folder", "under-a-file", "long-name"])
def test_train_out_that_cannot_be_written_fails_before_training(run_cli, data_dir, tmp_path, kind):
    (tmp_path / "file").write_text("x")
    out = {"folder": tmp_path, "under-a-file": tmp_path / "file" / "p.pt", "long-name": tmp_path / ("p" * 260)}[kind]
    code, _, err = run_cli("train", data_dir / WALK, "--out", out, "--iterations", "1")
    one_line_error(code, err, "error: ")
    assert "Traceback" not in err


def test_a_non_finite_loss_stops_training_and_writes_nothing(real_clips, tmp_path):
    walk = next(m for m in real_clips if "walk" in m.name)
    joints = walk.joints.copy()
    joints[10:] *= 1e300  # what a 1e308 BVH frame used to become; load_motion now refuses it
    out = tmp_path / "nan.pt"
    config = PriorConfig(layers=1, width=16, heads=2, ff_width=16, max_frames=8)
    with pytest.raises(TrainingDiverged, match="NaN or infinite feature statistics"):
        train_prior(
            [Motion(joints, walk.fps, "huge")],
            str(out),
            config,
            TrainConfig(iterations=3, batch_size=4, checkpoint_every=1),
        )
    assert not out.exists()


def test_a_loss_that_turns_nan_stops_training(real_clips, tmp_path, monkeypatch):
    """A model whose output turns NaN mid-run (divergence): the run stops naming the iteration, nothing written."""
    from platypose.lifting.prior import model as prior_module

    calls = {"n": 0}
    forward = prior_module.MotionPrior.forward

    def diverging(self, x_t, t):
        calls["n"] += 1
        out = forward(self, x_t, t)
        return out * float("nan") if calls["n"] > 3 and self.training else out

    monkeypatch.setattr(prior_module.MotionPrior, "forward", diverging)
    out = tmp_path / "nan.pt"
    config = PriorConfig(layers=1, width=16, heads=2, ff_width=16, max_frames=8)
    with pytest.raises(TrainingDiverged, match="training diverged at iteration 4: the loss is nan"):
        train_prior(real_clips[:2], str(out), config, TrainConfig(iterations=6, batch_size=4, checkpoint_every=10))
    assert not out.exists()


def test_a_prior_with_nan_weights_is_refused(run_cli, tiny_prior, tmp_path):
    path = tmp_path / "nan.pt"
    with torch.no_grad():
        weight = tiny_prior.model.output.weight
        saved = weight.clone()
        weight[0, 0] = float("nan")
        try:
            save_prior(path, tiny_prior)
        finally:
            weight.copy_(saved)
    with pytest.raises(InputError, match=r"nan\.pt: prior weights 'output\.weight' hold NaN"):
        load_prior(path)
    code, _, err = run_cli("prior-info", path)
    one_line_error(code, err, "nan.pt", "hold NaN")


def test_a_prior_with_a_broken_config_is_refused(tiny_prior, tmp_path):
    path = tmp_path / "odd.pt"
    save_prior(path, tiny_prior)
    payload = torch.load(path, weights_only=True)
    payload["config"]["heads"] = 3
    torch.save(payload, path)
    with pytest.raises(InputError, match="not a valid platypose prior"):
        load_prior(path)


def test_the_shipped_prior_is_finite():
    bundle, _ = load_prior()
    assert all(bool(torch.isfinite(p).all()) for p in bundle.model.parameters())
    assert np.isfinite(bundle.normalizer.std).all()


@pytest.mark.parametrize(
    "options, needle",
    [
        ({"seed": 10**23}, "seed must be in 0..2**63-1"),
        ({"samples": 10**9}, "samples must be at most 5000"),
        ({"eta": float("nan")}, "eta must be a finite number"),
        ({"bone_weight": float("inf")}, "bone_weight must be a finite number"),
    ],
)
def test_sampler_options_out_of_range(options, needle):
    """--seed 1e23 and --samples 1e9 once ended in internal exceptions; infinite weights were accepted."""
    from platypose.lifting.settings import SamplerConfig

    with pytest.raises(ValueError, match=needle.replace("*", r"\*").replace(".", r"\.")):
        SamplerConfig(**options)


def test_distilling_into_the_teacher_is_refused(run_cli, data_dir, prior_file, tmp_path) -> None:
    teacher = tmp_path / "teacher.pt"
    shutil.copy(prior_file, teacher)
    before = teacher.read_bytes()
    (tmp_path / "link.pt").symlink_to(teacher)
    for out in (teacher, tmp_path / "link.pt", tmp_path / "." / "teacher.pt"):
        code, _, err = run_cli(
            "train", str(data_dir / "motion/deepmimic"), "--out", str(out), "--distil-from", str(teacher),
            "--iterations", "1",
        )  # fmt: skip
        assert code == 2 and "is the teacher given by --distil-from" in err, err
    assert teacher.read_bytes() == before


CASES: list[Case] = []
case = registry(CASES)


@case("prior-with-nan-weights-prior-info")
def _(w: Path) -> Run:
    payload = torch.load(REPO / "lifting/prior/weights/default.pt", weights_only=True)
    first = next(iter(payload["state_dict"]))
    payload["state_dict"][first] = payload["state_dict"][first] * float("nan")
    torch.save(payload, w / "nan.pt")
    return Run(["prior-info", w / "nan.pt"], says=("nan.pt: prior weights 'input.weight' hold NaN or infinite values",))


@case("lift-seed-1e23")
def _(w: Path) -> Run:
    args = [*lift_args(openpose_copy(w), w / "out"), "--seed", str(10**23)]
    return Run(args, says=("--seed must be in 0..2**63-1, got 100000000000000000000000",))


@case("lift-samples-1e9")
def _(w: Path) -> Run:
    args = [*lift_args(openpose_copy(w), w / "out"), "--samples", str(10**9)]
    return Run(args, says=("--samples must be at most 5000, got 1000000000",))


@pytest.mark.audit
@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
