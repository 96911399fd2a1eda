"""Options of lift, eval, bench and demo come from the library's settings classes: one table row per field."""

import subprocess
import sys
import typing

import pytest

from platypose.cli.terminal.options import SETTINGS, TEXT, cli_message, flags
from platypose.lifting.errors import InputError


@pytest.mark.parametrize("group", sorted(SETTINGS))
def test_every_flag_is_a_field_of_its_class_with_its_type_default_and_help(group):
    cls = SETTINGS[group]
    hints = typing.get_type_hints(cls)
    made = flags(group)
    assert made
    for flag in made:
        field = cls.__dataclass_fields__[flag.field]
        typed = flag.type in (hints[flag.field], *typing.get_args(hints[flag.field]))
        assert typed or ((group, flag.field) in TEXT and flag.type is str), flag.field
        assert flag.default == field.default and flag.help == field.metadata["help"] and flag.help
        assert all(n.startswith("--") for n in flag.names)


@pytest.mark.parametrize("command", [[], ["lift"]])  # every command registers on import: lift builds the most
def test_help_imports_no_torch_numpy_or_cv2(command):
    """``python -X importtime -m platypose ... --help`` lists every module it imports."""
    done = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "platypose", *command, "--help"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0 and "Usage" in done.stdout, done.stderr[-500:]
    imported = {line.split("|")[-1].strip().split(".")[0] for line in done.stderr.splitlines() if "|" in line}
    assert "typer" in imported and not imported & {"torch", "numpy", "cv2", "scipy", "av"}, command


def test_help_shows_switches_without_a_type_and_options_in_panels(run_cli):
    code, out, _ = run_cli("lift", "--help-all")
    assert code == 0 and "<bool>" not in out
    for panel in ("Input", "Output", "People", "Sampler", "Ray", "Experimental"):
        assert f"─ {panel} " in out, panel
    assert out.index("─ Experimental ") > out.index("--samples") and "--temperature" in out.split("─ Experimental ")[1]


def test_help_shows_a_settings_default_as_its_value(run_cli):
    code, out, _ = run_cli("lift", "--help-all")
    assert code == 0 and "[default: 50]" in out and "[default: ddim]" in out and "(50)" not in out
    assert "[default: (" not in " ".join(out.split())  # not as a description in brackets


def test_an_option_left_at_its_default_is_not_given(monkeypatch):
    """A settings option is given only when typed: one the user leaves out takes the class's (or command's) default
    however --help shows it (``train`` builds one of two classes from the values given)."""
    import typer
    from typer.testing import CliRunner

    from platypose.cli.terminal.options import settings_options

    seen = []
    app = typer.Typer()

    @app.command()
    @settings_options("train", parameter="given", given_only=True)
    def show(given: dict = None) -> None:
        seen.append(given)

    assert CliRunner().invoke(app, ["--iterations", "7"]).exit_code == 0
    assert seen == [{"iterations": 7}]


def test_lift_eval_and_bench_spell_the_shared_options_alike(run_cli):
    for command in ("lift", "eval", "bench"):
        code, out, _ = run_cli(command, "--help-all" if command == "lift" else "--help")
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
    assert code == 2 and "--guidance-iters must be >= 0" in err
    code, _, err = run_cli(
        "eval", data_dir / "motion/deepmimic/humanoid3d_walk.txt", "--prior", prior_file, "--lambda", "0"
    )
    assert code == 2 and "--energy-scale must be positive" in err


def test_lift_md_tables_every_option_of_lift():
    """docs/lift.md's option table (right after the quick start) names every flag ``platypose lift`` takes."""
    from pathlib import Path

    import typer

    from platypose.cli.app import app, register_commands

    register_commands()
    lift = typer.main.get_command(app).commands["lift"]
    doc = (Path(__file__).resolve().parents[2] / "docs" / "lift.md").read_text(encoding="utf-8")
    table = doc.split("## Options", 1)[1].split("\n## ", 1)[0]
    flags = [o.split("/")[0] for p in lift.params for o in p.opts if o.startswith("--")]
    assert len(flags) > 40 and [f for f in flags if f"`{f}" not in table] == []
    assert doc.index("## Quick start") < doc.index("## Options") < doc.index("## What is one input")


def test_lift_help_fits_one_screen_with_the_common_options_and_help_all_shows_every_one():
    """At 80 columns ``lift --help`` is at most 60 lines: the options most people use, then where the rest are;
    ``--help-all`` shows every option of the command (and they all still work: a hidden one is only not shown)."""
    import os
    import re

    from platypose.cli.commands_lift import LIFT_SHOWN

    env = {**os.environ, "COLUMNS": "80", "TERM": "dumb"}
    run = [sys.executable, "-m", "platypose", "lift"]
    short = subprocess.run([*run, "--help"], capture_output=True, text=True, timeout=120, env=env).stdout
    full = subprocess.run([*run, "--help-all"], capture_output=True, text=True, timeout=120, env=env).stdout
    assert 20 < len(short.splitlines()) <= 60, len(short.splitlines())
    assert max(len(line) for line in short.splitlines()) <= 80
    for flag in ("--cams", "--keypoints", "--out", "--formats", "--persons", "--samples", "--threads", "--help-all"):
        assert flag in short, flag
    assert "--temperature" not in short and "--executor" not in short and "--help-all." in short
    assert len(LIFT_SHOWN) == 11 and len(full.splitlines()) > 150
    listed = set(re.findall(r"(--[a-z][a-z0-9-]*)", full))
    assert {"--temperature", "--executor", "--ray-address", "--floor", "--sync", "--seed", "--prior"} <= listed


def test_lift_always_writes_the_npz(tmp_path):
    """The npz is the source of truth (export and info read it): lift writes it whatever --formats names."""
    from platypose.cli.commands_lift import lift_settings
    from platypose.lifting.settings import DetectOptions, PriorSettings, SamplerConfig, WindowSettings

    settings = lift_settings(
        out=tmp_path,
        cams=None,
        prior=PriorSettings(),
        detect=DetectOptions(),
        sampler=SamplerConfig(),
        windows=WindowSettings(),
        formats="trc,angles,report",
        persons="all",
        root="auto",
        root_file=None,
        quiet=True,
        arguments={},
    )
    assert settings.formats == ("npz", "trc", "angles", "report")


def test_lift_md_says_how_many_cameras_the_demo_runs():
    from pathlib import Path

    from platypose.cli.commands_demo import demo_job, demo_take

    views = len(demo_job(demo_take(), "videos").views)
    doc = (Path(__file__).resolve().parents[2] / "docs" / "lift.md").read_text(encoding="utf-8")
    line = next(line for line in doc.splitlines() if line.startswith("platypose demo  "))  # the quick start
    assert f"({views} of its 4 cameras)" in line
