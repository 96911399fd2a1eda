"""A prior checkpoint is checked before its network is built: its joint names are a list of ours, its weights'
names and shapes are those its config asks for, and the config asks for a bounded network. Sampler numbers are
bounded so float32 arithmetic stays finite. The audit cases (marker ``audit``) give priors with bad settings to
``prior-info`` and a teacher as its own student to ``train`` (:mod:`audit_watch`)."""

from __future__ import annotations

import resource
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from audit_watch import PRIOR, REPO, check

from platypose.lifting.errors import InputError
from platypose.lifting.prior.model import load_prior, save_prior
from platypose.lifting.settings import SamplerConfig


def _edited(tiny_prior, tmp_path, change) -> str:
    path = tmp_path / "edited.pt"
    save_prior(path, tiny_prior)
    payload = torch.load(path, weights_only=True)
    change(payload)
    torch.save(payload, path)
    return str(path)


@pytest.mark.parametrize(
    "change, words",
    [
        (lambda p: p.pop("joint_names"), "joint_names must be a list of joint names, got NoneType"),
        (lambda p: p.update(joint_names=5), "joint_names must be a list of joint names, got int"),
        (lambda p: p.update(joint_names=["a"] * 17), "the prior was trained on another joint set"),
    ],
)
def test_joint_names_are_checked(tiny_prior, tmp_path, run_cli, change, words) -> None:
    path = _edited(tiny_prior, tmp_path, change)
    with pytest.raises(InputError, match=f"edited.pt: not a valid platypose prior \\({words}\\)"):
        load_prior(path)
    code, _, err = run_cli("prior-info", path)
    assert code == 2 and err.strip() == f"error: {path}: not a valid platypose prior ({words})"


def test_a_huge_config_is_refused_before_the_network_is_built(tiny_prior, tmp_path) -> None:
    """64 layers of width 4096 (each within its bound) is 12.9 billion weights: refused in seconds, no memory."""
    path = _edited(tiny_prior, tmp_path, lambda p: p["config"].update(layers=64, width=4096, heads=64, ff_width=16384))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(InputError, match=r"the config asks for 12,922,302,515 weights, over the 268,435,456"):
        load_prior(path)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 500_000  # kB: under 0.5 GB grown


def test_weights_of_another_shape_are_named(tiny_prior, tmp_path) -> None:
    path = _edited(tiny_prior, tmp_path, lambda p: p["config"].update(width=128, ff_width=256))
    with pytest.raises(
        InputError, match=r"weights 'input.weight' have shape \(64, 51\), the config asks for \(128, 51\)"
    ):
        load_prior(path)


@pytest.mark.parametrize(
    ("value", "shown"),
    [(1e308, "1e+308"), (np.float64(1e308), "1e+308"), (1e7, "10000000.0"), (1e6 + 0.5, "1000000.5")],
)
def test_sampler_numbers_are_bounded(value, shown) -> None:
    with pytest.raises(InputError) as err:
        SamplerConfig(energy_scale=value)
    assert str(err.value) == f"energy_scale must be between -1,000,000 and 1,000,000, got {shown}"  # not "1e+06"
    assert err.value.option == "energy_scale"


@pytest.mark.parametrize("value", [1e308, 86400.5, -1.0])
def test_max_gap_is_bounded_to_a_day(value) -> None:
    from platypose.lifting.settings import WindowSettings

    with pytest.raises(InputError) as err:
        WindowSettings(max_gap=value)
    assert str(err.value) == f"max_gap must be a number of seconds from 0 to 86400 (a day), got {value!r}"


def _edited_prior(source, path, edit) -> str:
    """The checkpoint ``source`` with ``edit(payload)`` applied, saved to ``path``."""
    import torch

    payload = torch.load(source, weights_only=True)
    edit(payload)
    torch.save(payload, path)
    return str(path)


@pytest.mark.parametrize(
    "edit, needle",
    [
        (lambda p: p["config"].update(diffusion_steps=1e9), "diffusion_steps must be a whole number"),
        (lambda p: p["config"].update(diffusion_steps=10**9), "diffusion_steps must be within"),
        (lambda p: p["config"].update(layers=10**6), "layers must be within"),
        (
            lambda p: p["config"].update(width="64"),
            "not a valid platypose prior (width must be a whole number, got '64')",
        ),
        (lambda p: p.update(config=[1, 2]), "not a valid platypose prior"),
        (lambda p: p["manifest"].update(sampling_steps=[10**12, 3]), "sampling_steps must be decreasing"),
        (lambda p: p["manifest"].update(distilled={"x": 1}), "'distilled' is damaged"),
        (lambda p: p["manifest"].update(clips=[{"name": 3}]), "'clips' must list"),
        (lambda p: p["normalizer"].update(mean=[0.0] * 7), "normalisation does not have"),
        (lambda p: p.pop("normalizer"), "not a valid platypose prior (no 'normalizer')"),
    ],
)
def test_prior_config_and_manifest_are_validated(run_cli, prior_file, tmp_path, edit, needle) -> None:
    bad = _edited_prior(prior_file, tmp_path / "bad.pt", edit)
    code, _, err = run_cli("prior-info", bad)
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, err
    assert "Error" not in err  # the problem, not the name of a Python exception


@pytest.mark.audit
def test_distilling_into_the_teacher_is_refused(tmp_path: Path) -> None:
    teacher = tmp_path / "teacher.pt"
    shutil.copy(PRIOR, teacher)
    before = teacher.read_bytes()
    args = ["train", REPO / "data/motion/deepmimic", "--out", teacher, "--distil-from", teacher, "--iterations", "1"]
    check(tmp_path / "case", args, "error", ("teacher.pt", "is the teacher given by --distil-from"))
    assert teacher.read_bytes() == before


@pytest.mark.audit
@pytest.mark.parametrize(
    ("name", "edit", "needle"),
    [
        ("steps-1e9", lambda p: p["config"].update(diffusion_steps=1e9), "diffusion_steps"),
        ("steps-int-1e9", lambda p: p["config"].update(diffusion_steps=10**9), "diffusion_steps"),
        ("layers-1e6", lambda p: p["config"].update(layers=10**6), "layers"),
        ("width-str", lambda p: p["config"].update(width="64"), "not a valid"),
        ("fps-nan", lambda p: p["config"].update(fps=float("nan")), "fps"),
        ("sampling-steps", lambda p: p["manifest"].update(sampling_steps=[10**12]), "sampling_steps"),
        ("clips-bad", lambda p: p["manifest"].update(clips=[{"name": 1}]), "clips"),
        ("manifest-list", lambda p: p.update(manifest=[1]), "manifest"),
    ],
    ids=[
        "steps-1e9",
        "steps-int-1e9",
        "layers-1e6",
        "width-str",
        "fps-nan",
        "sampling-steps",
        "clips-bad",
        "manifest-list",
    ],
)
def test_priors_with_bad_settings(tmp_path: Path, name: str, edit, needle: str) -> None:
    import torch

    payload = torch.load(PRIOR, weights_only=True)
    edit(payload)
    torch.save(payload, tmp_path / f"{name}.pt")
    check(tmp_path / "case", ["prior-info", tmp_path / f"{name}.pt"], "error", (f"{name}.pt", needle))
