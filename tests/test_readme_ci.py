"""README's two commands: the first installs no test extra, the second installs it itself, and CI runs both as
written (.ci/run), the test extra before ruff."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_ci_runs_readmes_commands_as_written_and_the_user_install_has_no_test_extra():
    commands = re.findall(r"```bash\n(.*?)\n```", (ROOT / "README.md").read_text(encoding="utf-8"), re.S)
    setup, tests = commands[:2]
    assert "pip install -e . &&" in setup and "[test]" not in setup and setup.endswith("platypose demo")
    assert tests.startswith('.venv/bin/pip install -e ".[test]" && ') and "pytest" in tests
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert setup in ci and tests in ci
    extra = ci.index('.venv/bin/pip install -e ".[test]"')
    assert ci.index(setup) < extra < next(i for i, line in enumerate(ci) if line.startswith(".venv/bin/ruff"))
