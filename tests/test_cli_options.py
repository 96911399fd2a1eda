"""Options of lift, eval, bench and demo come from the library's settings classes: one table row per field."""

import typing
from dataclasses import fields

import pytest

from platypose.cli.options import SETTINGS, cli_message, declared_defaults, settings_class
from platypose.lifting.errors import InputError


@pytest.mark.parametrize("group", sorted(SETTINGS))
def test_every_flag_names_a_field_of_its_class_with_its_type(group):
    cls = settings_class(group)
    hints = typing.get_type_hints(cls)
    names = {f.name for f in fields(cls)}
    for flag in SETTINGS[group][2]:
        assert flag.field in names, f"{group}: {flag.field} is not a field of {cls.__name__}"
        assert flag.type in (hints[flag.field], *typing.get_args(hints[flag.field])), flag.field
        assert all(n.startswith("--") for n in flag.names)
    shown = declared_defaults(group)  # what --help shows, read without importing the class
    assert shown == {f.name: f.default for f in fields(cls) if f.name in shown}
    assert {f.field for f in SETTINGS[group][2]} <= set(shown)


def test_lift_eval_and_bench_spell_the_shared_options_alike(run_cli):
    for command in ("lift", "eval", "bench"):
        code, out, _ = run_cli(command, "--help")
        assert code == 0
        for flag in ("--guidance-iters", "--seed", "--prior", "--device", "--runtime", "--robust"):
            assert flag in out, (command, flag)


def test_library_errors_name_fields_and_the_cli_names_flags():
    err = InputError("persons must be 'all', 'largest' or a positive number, got 'x'", option="persons")
    assert str(err).startswith("persons must") and cli_message(err).startswith("--persons must")
    err = InputError("model.onnx: unknown detector format 'x'; known: movenet", option="detector format")
    assert cli_message(err) == "model.onnx: unknown --detector-format 'x'; known: movenet"
    assert cli_message(InputError("unknown device 'tpu'")) == "unknown device 'tpu'"
    err = InputError(
        "/data/subject/h36m.json: several subjects; give subject, one with extrinsics: S1", option="subject"
    )
    assert cli_message(err) == "/data/subject/h36m.json: several subjects; give --subject, one with extrinsics: S1"
    err = InputError("device cuda: this torch build sees no CUDA GPU (choose cpu or auto)", option="device")
    assert cli_message(err).startswith("--device cuda: ")


def test_old_eval_spellings_still_work(run_cli, prior_file, data_dir):
    code, _, err = run_cli(
        "eval", data_dir / "motion/deepmimic/humanoid3d_walk.txt", "--prior", prior_file, "--k", "-1"
    )
    assert code == 2 and "guidance iterations must be >= 0" in err
    code, _, err = run_cli(
        "eval", data_dir / "motion/deepmimic/humanoid3d_walk.txt", "--prior", prior_file, "--lambda", "0"
    )
    assert code == 2 and "energy scale must be positive" in err
