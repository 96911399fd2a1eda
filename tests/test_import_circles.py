"""No import circle in the package: no module of platypose (lifting, detectors, exporters, the pipeline and API, the
command line) imports, at any depth of the file (lazy imports included), a module that imports it back; a
package's modules import their siblings, not the package's ``__init__``. And no module reaches into another's
private names."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# Repository folder -> the package it installs as (pyproject.toml's package-dir).
PACKAGES = {
    "lifting": "platypose.lifting",
    "detectors": "platypose.detectors",
    "exporters": "platypose.exporters",
    "platypose": "platypose",
    "platypose_cli": "platypose.cli",
}


def modules() -> dict[str, Path]:
    """Every module of the package by its dotted name (a package by its own name, for its ``__init__``)."""
    found = {}
    for folder, package in PACKAGES.items():
        for path in sorted((REPO / folder).rglob("*.py")):
            parts = [p for p in path.relative_to(REPO / folder).with_suffix("").parts if p != "__init__"]
            found[".".join([package, *parts])] = path
    return found


def imports(name: str, path: Path) -> list[tuple[str, list[str]]]:
    """(module, names) of every ``import`` and ``from ... import`` in ``path`` (at any depth: lazy ones too)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(alias.name, []) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")[: len(name.split(".")) - node.level + (path.name == "__init__.py")]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module
            found.append((module, [alias.name for alias in node.names]))
    return found


def import_graph() -> dict[str, set[str]]:
    """Module -> the package's modules it imports (``from a.b import c`` counts as ``a.b`` and, a module, ``a.b.c``)."""
    known = modules()
    graph = {}
    for name, path in known.items():
        edges = set()
        for module, names in imports(name, path):
            edges |= {m for m in (module, *(f"{module}.{n}" for n in names)) if m in known and m != name}
        graph[name] = edges
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for other in sorted(graph[node]):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while not component or component[-1] != node:
                component.append(stack.pop())
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def private(name: str) -> bool:
    """Whether ``name`` is private: one leading underscore (``__version__`` and the like are not)."""
    return name.startswith("_") and not name.startswith("__")


def test_no_module_imports_itself_through_others():
    graph = import_graph()
    assert len(graph) > 200 and sum(map(len, graph.values())) > 500
    assert circles(graph) == []


def test_the_circle_finder_finds_a_circle_and_a_package_imported_by_its_module():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert circles({"p": {"p.m"}, "p.m": {"p"}}) == [["p", "p.m"]]


def test_no_private_name_crosses_a_module():
    """Neither ``from platypose... import _name`` nor ``Name._name`` on a name imported from platypose (a module, a
    class, or an object one makes: ``Class(...)._name``)."""
    crossing = []
    for name, path in modules().items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        ours = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("platypose"):
                crossing += [f"{name}: {node.module}.{a.name}" for a in node.names if private(a.name)]
                ours |= {a.asname or a.name for a in node.names}
            elif isinstance(node, ast.Import):
                ours |= {a.asname or a.name.split(".")[0] for a in node.names if a.name.startswith("platypose")}
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and private(node.attr):
                owner = node.value.func if isinstance(node.value, ast.Call) else node.value
                if isinstance(owner, ast.Name) and owner.id in ours:
                    crossing.append(f"{name}: {owner.id}.{node.attr}")
    assert crossing == []
