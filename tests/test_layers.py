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
        "platypose.take_pipeline",
    ),
    "detectors": ("platypose.exporters", "platypose.cli", "platypose.pipeline", "platypose.take_pipeline"),
    "exporters": ("platypose.detectors", "platypose.cli", "platypose.pipeline", "platypose.take_pipeline"),
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
