"""Module sizes: no module of the installed folders is over 400 lines (data tables excepted), and the size table
of docs/architecture.md is the one tools/module_sizes.py makes from the code as it is."""

import importlib.util
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TOOL = REPO / "tools" / "module_sizes.py"


def _tool():
    spec = importlib.util.spec_from_file_location("module_sizes", TOOL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_no_module_over_the_limit():
    done = subprocess.run([sys.executable, str(TOOL), "--check"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stdout


def test_architecture_md_shows_the_table_of_the_code_as_it_is():
    sizes = _tool()
    shown = sizes.documented(REPO / "docs" / "architecture.md")
    assert shown, "docs/architecture.md has no size table between the markers"
    assert shown == sizes.table(sizes.module_lines()), "stale size table: run python tools/module_sizes.py --write"
