"""The command line's shape (platypose_cli/, installed as platypose.cli): the top level holds only the app and the
commands, its modules import one another without a circle (lazy imports included), and no module reaches into
another's private names."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CLI = REPO / "platypose_cli"


def modules() -> dict[str, Path]:
    """Every module of platypose.cli by its dotted name."""
    found = {}
    for path in sorted(CLI.rglob("*.py")):
        parts = [p for p in path.relative_to(CLI).with_suffix("").parts if p != "__init__"]
        found[".".join(["platypose.cli", *parts])] = path
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
    """Module -> the modules of platypose.cli it imports (``from package import module`` counts as the module)."""
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


def test_the_top_level_holds_only_the_app_and_the_commands():
    loose = [p.name for p in CLI.glob("*.py") if p.name not in ("__init__.py", "app.py")]
    assert loose and all(name.startswith("commands_") for name in loose), loose


def test_no_module_imports_itself_through_others():
    graph = import_graph()
    assert len(graph) > 30 and any(graph.values())
    assert circles(graph) == []


def test_the_circle_finder_finds_a_circle():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


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
