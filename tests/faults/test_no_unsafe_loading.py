"""Nothing in the package unpickles or runs code from a file (np.load with pickles, torch.load
without weights_only, yaml.load, pickle.load, eval, exec); the one allowed unpickler resolves numpy arrays only."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PACKAGES = ("detectors", "exporters", "lifting", "platypose", "platypose_cli", "tools")
SAFE_UNPICKLER = REPO / "lifting/motion_io/safe_unpickle.py"
# eval of the package's own annotation strings (typer options from its settings classes), never of file content
OWN_ANNOTATIONS = REPO / "platypose_cli/terminal/options.py"


def _calls(path: Path):
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Call):
            yield node, ast.unparse(node.func)


def _keyword(call: ast.Call, name: str):
    return next((k.value for k in call.keywords if k.arg == name), None)


def test_no_code_running_loaders_in_the_package():
    problems = []
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            for call, name in _calls(path):
                where = f"{path.relative_to(REPO)}:{call.lineno}"
                if name in ("np.load", "numpy.load"):
                    flag = _keyword(call, "allow_pickle")
                    if not (isinstance(flag, ast.Constant) and flag.value is False):
                        problems.append(f"{where}: np.load without allow_pickle=False")
                elif name == "torch.load":
                    flag = _keyword(call, "weights_only")
                    if not (isinstance(flag, ast.Constant) and flag.value is True):
                        problems.append(f"{where}: torch.load without weights_only=True")
                elif name == "eval" and path == OWN_ANNOTATIONS and ast.unparse(call.args[0]) == "annotation":
                    continue
                elif name in ("eval", "exec", "yaml.load", "yaml.unsafe_load", "marshal.loads", "shelve.open"):
                    problems.append(f"{where}: {name}")
                elif name in ("pickle.load", "pickle.loads", "pickle.Unpickler") and path != SAFE_UNPICKLER:
                    problems.append(f"{where}: {name} outside the array-only unpickler")
    assert problems == []
