"""No module of the installed folders is over 400 lines (data tables excepted): tools/module_sizes.py --check."""

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_no_module_over_the_limit():
    done = subprocess.run(
        [sys.executable, str(REPO / "tools" / "module_sizes.py"), "--check"], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stdout


def test_architecture_md_shows_the_generated_table():
    text = (REPO / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert "<!-- module-sizes: tools/module_sizes.py --write -->" in text and "| `lifting/sampling/` |" in text
