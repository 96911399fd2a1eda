"""Module sizes of the installed folders, as docs/architecture.md shows them, and the 400-line limit.

python tools/module_sizes.py            # print the table (Markdown)
python tools/module_sizes.py --write    # put it into docs/architecture.md between its markers
python tools/module_sizes.py --check    # exit 1 naming every module over the limit (data tables excepted)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FOLDERS = ("lifting", "detectors", "exporters", "platypose", "platypose_cli")
LIMIT = 400  # lines per module
DATA_TABLES = ("lifting/joint_maps.py",)  # mostly joint tables: the limit does not apply
LONGEST = 8  # modules listed by name
BEGIN, END = "<!-- module-sizes: tools/module_sizes.py --write -->", "<!-- /module-sizes -->"


def module_lines() -> dict[str, int]:
    """Lines of every Python module under :data:`FOLDERS`, by repository path."""
    return {
        str(path.relative_to(REPO)): len(path.read_text(encoding="utf-8").splitlines())
        for folder in FOLDERS
        for path in sorted((REPO / folder).rglob("*.py"))
    }


def over_limit(lines: dict[str, int]) -> list[str]:
    """Modules longer than :data:`LIMIT` lines that are not data tables."""
    return [f"{path} ({count} lines)" for path, count in lines.items() if count > LIMIT and path not in DATA_TABLES]


def table(lines: dict[str, int]) -> str:
    """Markdown: modules and lines per package folder, then the longest modules."""
    packages: dict[str, list[int]] = {}
    for path, count in lines.items():
        packages.setdefault(str(Path(path).parent), []).append(count)
    rows = ["| folder | modules | lines | longest |", "|---|---|---|---|"]
    rows += [f"| `{folder}/` | {len(counts)} | {sum(counts)} | {max(counts)} |" for folder, counts in packages.items()]
    longest = sorted(lines.items(), key=lambda item: -item[1])[:LONGEST]
    listed = ", ".join(f"`{path}` ({count})" for path, count in longest)
    return "\n".join(rows) + f"\n\nThe longest modules: {listed}; the limit is {LIMIT} lines, data tables excepted.\n"


def documented(doc: Path) -> str:
    """The table ``doc`` shows between its markers, as :func:`table` writes it; empty without the markers."""
    _, begin, rest = doc.read_text(encoding="utf-8").partition(BEGIN)
    shown, end, _ = rest.partition(END)
    return shown.removeprefix("\n") if begin and end else ""


def write(doc: Path, text: str) -> None:
    """Replace what lies between the markers of ``doc`` with ``text``."""
    content = doc.read_text(encoding="utf-8")
    head, begin, rest = content.partition(BEGIN)
    _, end, tail = rest.partition(END)
    if not begin or not end:
        sys.exit(f"{doc}: markers {BEGIN} ... {END} not found")
    doc.write_text(f"{head}{BEGIN}\n{text}{END}{tail}", encoding="utf-8")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="update docs/architecture.md")
    parser.add_argument("--check", action="store_true", help="exit 1 if a module is over the limit")
    args = parser.parse_args()
    lines = module_lines()
    if args.check:
        over = over_limit(lines)
        print("\n".join(over) or f"no module over {LIMIT} lines")
        sys.exit(1 if over else 0)
    if args.write:
        write(REPO / "docs" / "architecture.md", table(lines))
    else:
        print(table(lines), end="")


if __name__ == "__main__":
    main()
