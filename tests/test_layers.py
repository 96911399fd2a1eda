"""The import layers hold one way: lifting imports nothing of ours above it; detectors and exporters share only
lifting and the video reader (platypose.media), never each other."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FORBIDDEN = {
    "lifting": (
        "platypose.detectors",
        "platypose.exporters",
        "platypose.media",
        "platypose.cli",
        "platypose.pipeline",
    ),
    "detectors": ("platypose.exporters", "platypose.cli", "platypose.pipeline"),
    "exporters": ("platypose.detectors", "platypose.cli", "platypose.pipeline"),
}


def imported_modules(path: Path) -> list[str]:
    """Every module ``path`` imports, at any depth of the file (lazy imports included)."""
    names = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.append(node.module)
    return names


@pytest.mark.parametrize("folder", sorted(FORBIDDEN))
def test_no_import_goes_up_or_across(folder: str) -> None:
    files = [*sorted((REPO / folder).rglob("*.py"))]
    offenders = [
        f"{path.relative_to(REPO)}: {name}"
        for path in files
        for name in imported_modules(path)
        if name.startswith(FORBIDDEN[folder])
    ]
    assert files and offenders == []


def test_media_imports_only_lifting() -> None:
    ours = [n for n in imported_modules(REPO / "platypose" / "media.py") if n.startswith("platypose")]
    assert ours and all(n.startswith("platypose.lifting") for n in ours)


OFFLINE_COMMANDS = {"commands_train.py", "commands_eval.py", "commands_bench.py"}  # train, eval, bench


def test_the_lift_path_never_imports_offline() -> None:
    """Training, distillation, evaluation and benchmarks (lifting/offline/) are imported only by each other and by
    the commands that run them: nothing a lift runs (lifting's other modules, detectors, exporters, the pipeline,
    the API, the lift command) loads them."""
    folders = ("lifting", "detectors", "exporters", "platypose", "platypose_cli")
    files = [
        path
        for folder in folders
        for path in sorted((REPO / folder).rglob("*.py"))
        if "offline" not in path.relative_to(REPO).parts and path.name not in OFFLINE_COMMANDS
    ]
    offenders = [
        f"{path.relative_to(REPO)}: {name}"
        for path in files
        for name in imported_modules(path)
        if name.startswith("platypose.lifting.offline")
    ]
    assert len(files) > 100 and offenders == []


def test_the_sampler_imports_no_take_level_module() -> None:
    """lifting/sampling/ (Algorithm 1) imports the base of lifting and the prior, never the take around it (tracks:
    windows and roots; finish: rigid people; sync; checks) nor offline."""
    take_level = tuple(f"platypose.lifting.{package}" for package in ("tracks", "finish", "sync", "checks", "offline"))
    imported = [
        (path, name)
        for path in sorted((REPO / "lifting" / "sampling").rglob("*.py"))
        for name in imported_modules(path)
    ]
    offenders = [f"{path.relative_to(REPO)}: {name}" for path, name in imported if name.startswith(take_level)]
    assert any(name.startswith("platypose.lifting.prior") for _, name in imported) and offenders == []
