"""The maps of the code stay true: docs/architecture.md (and every reference page) names only modules that exist and
functions they define, the map shows every part of lifting/, and every Sphinx-style reference in a docstring or
comment of the package (``:mod:``, ``:func:``, ``:class:``, ``:meth:``, ``:data:``, ``:attr:``, ``:exc:``) resolves."""

from __future__ import annotations

import ast
import importlib
import io
import re
import tokenize
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
ARCHITECTURE = DOCS / "architecture.md"
HISTORY = ("results.md",)  # the dated log: it names what was there at the time
# Repository folder -> the package it installs as (pyproject.toml's package-dir).
PACKAGES = {
    "lifting": "platypose.lifting",
    "detectors": "platypose.detectors",
    "exporters": "platypose.exporters",
    "platypose": "platypose",
    "platypose_cli": "platypose.cli",
}
PATH = re.compile(r"(?<![\w./<>-])((?:lifting|platypose|detectors|exporters|platypose_cli|tools)/(?:[\w]+/)*\w+\.py)")
FOLDER = re.compile(r"(?<![\w./<>-])((?:lifting|platypose|detectors|exporters|platypose_cli)/(?:\w+/)+)(?![\w.])")
DEFINED = re.compile(r"`((?:lifting|platypose|detectors|exporters|platypose_cli)/(?:\w+/)*\w+\.py): ([\w.]+)`")
ROLE = re.compile(r":(mod|func|class|meth|data|attr|exc):`([^`]+)`")


def reference_pages() -> list[Path]:
    return [page for page in sorted(DOCS.glob("*.md")) if page.name not in HISTORY]


def top_level_names(path: Path) -> dict[str, ast.AST]:
    """Functions, classes and assigned names at the top of the module ``path`` (imports excluded)."""
    names: dict[str, ast.AST] = {}
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names[node.name] = node
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                if isinstance(target, ast.Name):
                    names[target.id] = node
    return names


def defines(path: Path, dotted: str) -> bool:
    """Whether the module ``path`` defines ``dotted``: a top-level name, or ``Class.member``."""
    head, _, member = dotted.partition(".")
    node = top_level_names(path).get(head)
    if node is None or not member:
        return node is not None
    return isinstance(node, ast.ClassDef) and any(
        getattr(child, "name", None) == member
        or any(
            isinstance(t, ast.Name) and t.id == member
            for t in getattr(child, "targets", [getattr(child, "target", None)])
        )
        for child in node.body
    )


@pytest.mark.parametrize("page", reference_pages(), ids=lambda page: page.name)
def test_every_module_and_folder_a_page_names_exists(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    missing = sorted({p for p in PATH.findall(text) if not (REPO / p).is_file()})
    missing += sorted({f for f in FOLDER.findall(text) if not (REPO / f).is_dir()})
    assert not missing, f"{page.name} names what is not in the repository: {missing}"


@pytest.mark.parametrize("page", reference_pages(), ids=lambda page: page.name)
def test_every_function_a_page_places_in_a_module_is_defined_there(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    references = DEFINED.findall(text)
    wrong = [f"{path}: {name}" for path, name in references if not defines(REPO / path, name)]
    assert not wrong, f"{page.name} places these where they are not defined: {wrong}"


def test_the_map_holds_dotted_pipeline_references() -> None:
    """``platypose.pipeline.run_take`` and the like in the map name a function of that module."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    dotted = set(re.findall(r"platypose\.pipeline\.\w+", text))
    assert dotted, "the map names no function of the take pipeline"
    for name in dotted:
        assert defines(REPO / "platypose" / "pipeline.py", name.rsplit(".", 1)[1]), name


def test_the_map_shows_every_part_of_lifting() -> None:
    """Every sub-package of lifting/ is named as a folder, and every module at its top by its file name."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    packages = sorted(p.name for p in (REPO / "lifting").iterdir() if (p / "__init__.py").is_file())
    assert len(packages) >= 10, packages  # the map would pass vacuously on a flat lifting/
    absent = [f"lifting/{name}/" for name in packages if f"lifting/{name}/" not in text]
    modules = sorted(p.name for p in (REPO / "lifting").glob("*.py") if p.name != "__init__.py")
    absent += [f"lifting/{name}" for name in modules if f"`{name}`" not in text and f"lifting/{name}" not in text]
    assert not absent, f"docs/architecture.md does not show {absent}"


def module_name(path: Path) -> str:
    """The installed name of the module at repository path ``path``."""
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    parts[0] = PACKAGES[parts[0]]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def docstrings_and_comments(path: Path) -> Iterator[tuple[int, str, str | None]]:
    """(line, text, enclosing class) of every docstring and comment of the module ``path``."""
    source = path.read_text(encoding="utf-8")

    def walk(node: ast.AST, cls: str | None) -> Iterator[tuple[int, str, str | None]]:
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                yield node.body[0].lineno, doc, cls
        for child in ast.iter_child_nodes(node):
            yield from walk(child, child.name if isinstance(child, ast.ClassDef) else cls)

    yield from walk(ast.parse(source), None)
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            yield token.start[0], token.string, None


def resolves(dotted: str) -> bool:
    """Whether ``dotted`` is a module, or an attribute reached from the longest importable module prefix of it."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            target = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for part in parts[cut:]:
            if not hasattr(target, part):
                return False
            target = getattr(target, part)
        return True
    return False


def candidates(target: str, module: str, cls: str | None) -> list[str]:
    """Where a role's ``target`` may live: as written (``platypose.`` added where missing), or in the module (and
    class) whose docstring names it."""
    name = target.strip().lstrip("~").removesuffix("()")
    found = [name] if name.startswith("platypose.") else [f"platypose.{name}"]
    found.append(f"{module}.{name}")
    if cls:
        found.append(f"{module}.{cls}.{name}")
    return found


def test_every_docstring_reference_resolves() -> None:
    references = 0
    broken = []
    for folder in PACKAGES:
        for path in sorted((REPO / folder).rglob("*.py")):
            module = module_name(path)
            for line, text, cls in docstrings_and_comments(path):
                for _, target in ROLE.findall(text):
                    references += 1
                    if not any(resolves(name) for name in candidates(target, module, cls)):
                        broken.append(f"{path.relative_to(REPO)}:{line}: {target}")
    assert references > 100, references  # the scan found the package's references
    assert not broken, "docstring references that name nothing:\n" + "\n".join(broken)


def test_docstrings_name_no_lifting_module_that_is_not_there() -> None:
    """Dotted mentions outside roles (``lifting.sampling.views``) name a module or what it holds, too."""
    dotted = re.compile(r"(?<![\w./])(?:platypose\.)?(?:lifting|detectors|exporters)(?:\.\w+)+")
    broken = []
    for folder in PACKAGES:
        for path in sorted((REPO / folder).rglob("*.py")):
            for line, text, _ in docstrings_and_comments(path):
                for mention in dotted.findall(text):
                    name = mention if mention.startswith("platypose.") else f"platypose.{mention}"
                    if not resolves(name):
                        broken.append(f"{path.relative_to(REPO)}:{line}: {mention}")
    assert not broken, "docstrings name modules that are not there:\n" + "\n".join(broken)


def anchors(page: Path) -> set[str]:
    """The anchors of a Markdown page: GitHub's slug of every heading (repeats numbered), and every ``<a id>``."""
    text = page.read_text(encoding="utf-8")
    found = set(re.findall(r'<a id="([^"]+)">', text))
    seen: dict[str, int] = {}
    in_code = False
    for line in text.splitlines():
        if line.startswith("```"):
            in_code = not in_code
        heading = re.match(r"#{1,6} (.+)", line)
        if heading and not in_code:
            slug = re.sub(r"[^\w\- ]", "", heading.group(1).strip().lower()).replace(" ", "-")
            found.add(slug if slug not in seen else f"{slug}-{seen[slug]}")
            seen[slug] = seen.get(slug, 0) + 1
    return found


@pytest.mark.parametrize("page", [*reference_pages(), REPO / "README.md"], ids=lambda page: page.name)
def test_every_link_into_a_page_finds_its_anchor(page: Path) -> None:
    """A link such as ``results.md#speed`` or ``#gaps`` lands on a heading or an ``<a id>`` of that page."""
    wrong = []
    for target, anchor in re.findall(r"\]\(((?:[\w./-]+\.md)?)#([\w-]+)\)", page.read_text(encoding="utf-8")):
        linked = page if not target else (page.parent / target).resolve()
        if not linked.is_file() or anchor not in anchors(linked):
            wrong.append(f"{target}#{anchor}")
    assert not wrong, f"{page.name} links to anchors that are not there: {wrong}"
