"""The take path takes values, not lists of parameters: no function of ``platypose/pipeline.py``, ``lifting/tracks/``,
``lifting/finish/``, ``lifting/sampling/`` or the command's runner (every module under ``platypose_cli/``, wherever
it is moved there) takes more than ``MAX_POSITIONAL`` positional parameters (``self`` and ``cls`` aside; the
keyword-only ones after ``*`` do not count). Callers name what they pass. A command (a function decorated
``@app.command(...)`` or ``.callback(...)``) takes its options as Typer declares them, by name: it is not counted."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MAX_POSITIONAL = 7
TAKE_PATH = ("platypose/pipeline.py", "lifting/tracks", "lifting/finish", "lifting/sampling", "platypose_cli")


def take_path_files(root: Path) -> list[Path]:
    """The modules of the take path under ``root`` (a checkout)."""
    files = []
    for part in TAKE_PATH:
        path = root / part
        files += [path] if path.is_file() else sorted(path.rglob("*.py"))
    return files


def is_command(node: ast.AST) -> bool:
    """Whether ``node`` is a Typer command or callback (decorated ``X.command(...)`` or ``X.callback(...)``)."""
    return any(
        isinstance(d, ast.Call) and isinstance(d.func, ast.Attribute) and d.func.attr in ("command", "callback")
        for d in getattr(node, "decorator_list", [])
    )


def long_signatures(path: Path, root: Path = REPO) -> list[str]:
    """``file:line name (n)`` for each function of ``path`` with more than ``MAX_POSITIONAL`` positional parameters."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)) and not is_command(node):
            positional = [a.arg for a in node.args.posonlyargs + node.args.args]
            if positional[:1] in (["self"], ["cls"]):
                positional = positional[1:]
            if len(positional) > MAX_POSITIONAL:
                name = getattr(node, "name", "lambda")
                found.append(f"{path.relative_to(root)}:{node.lineno} {name} ({len(positional)})")
    return found


def test_the_take_path_is_found() -> None:
    files = take_path_files(REPO)
    assert REPO / "platypose" / "pipeline.py" in files
    assert any(f.parent.name == "tracks" for f in files) and any(f.parent.name == "finish" for f in files)
    assert any("platypose_cli" in f.parts for f in files)


def test_a_long_signature_is_found_and_keyword_only_parameters_are_not_counted(tmp_path: Path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text(
        "def f(a, b, c, d, e, f, g, h):\n    pass\n\n"
        "def g(self, a, b, c, d, e, f, g, *, h):\n    pass\n\n"
        "@app.command()\ndef h(a, b, c, d, e, f, g, h):\n    pass\n"
    )
    assert [line.split()[-2:] for line in long_signatures(probe, tmp_path)] == [["f", "(8)"]]


def test_no_function_on_the_take_path_takes_more_than_seven_positional_parameters() -> None:
    found = [line for path in take_path_files(REPO) for line in long_signatures(path)]
    assert not found, "take more than 7 positional parameters (pass a value, or make the rest keyword-only):\n" + (
        "\n".join(found)
    )
