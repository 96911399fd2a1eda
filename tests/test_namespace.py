"""One installed namespace: every import of our code goes through ``platypose.*``."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FOLDERS = ("platypose", "platypose_cli", "lifting", "detectors", "exporters", "data", "tools", "tests")
BARE = {"lifting", "detectors", "exporters", "platypose_cli", "data"}


def bare_imports(path: Path) -> list[str]:
    """Imports in ``path`` of a repository folder by its bare name (which would load it a second time)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        found += [f"{path.relative_to(REPO)}:{node.lineno}: {n}" for n in names if n.split(".")[0] in BARE]
    return found


def test_no_code_imports_a_folder_by_its_bare_name() -> None:
    offenders = [
        hit for folder in FOLDERS for path in sorted((REPO / folder).rglob("*.py")) for hit in bare_imports(path)
    ]
    assert offenders == []


def test_installed_package_resolves_outside_the_checkout(tmp_path) -> None:
    """From another folder (no checkout on sys.path) the sub-packages, the data and the entry point resolve."""
    code = (
        "import platypose, platypose.lifting, platypose.cli.app, platypose.data as d; "
        "assert (d.VIDEO_DIR / 'pose2sim-balancing' / 'calib_pose2sim.toml').is_file(); "
        "import importlib.util as u; print(u.find_spec('lifting'), u.find_spec('exporters'))"
    )
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["None", "None"]  # no generic top-level names installed


def test_every_sub_package_is_installed() -> None:
    """pyproject.toml lists every folder with an ``__init__.py`` under the installed folders as a package (setuptools
    installs only those listed: a sub-package left out is missing from ``pip install .``, not from the checkout)."""
    listed = set(re.findall(r'^\s*"(platypose[\w.]*)",?\s*$', (REPO / "pyproject.toml").read_text(), re.M))
    folders = {"platypose": "platypose", "platypose_cli": "platypose.cli", "data": "platypose.data"}
    folders |= {name: f"platypose.{name}" for name in ("lifting", "detectors", "exporters")}
    found = {
        ".".join([package, *init.parent.relative_to(REPO / folder).parts])
        for folder, package in folders.items()
        for init in (REPO / folder).rglob("__init__.py")
    }
    assert len(found) > 20 and found - listed == set(), sorted(found - listed)
