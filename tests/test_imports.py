"""The package's import structure: no import cycle, and every package installed.

The cycle test reads the sources with :mod:`ast` (nothing is imported), so it
sees every import a module may execute: at module level, inside functions
(deferred imports still close a cycle once they run) and in any branch.
Relative imports are resolved against the importing module's package, and
``from pkg import name`` points at the submodule ``pkg.name`` when there is one,
else at the package ``pkg`` itself.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "mcocl"


def module_name(path: Path, root: Path = ROOT) -> str:
    """The dotted name of a source file under ``root`` (the folder that holds the package)."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def package_modules(package: Path = PACKAGE) -> dict[str, Path]:
    """Every module of a package folder, by dotted name."""
    return {module_name(p, package.parent): p for p in sorted(package.rglob("*.py"))}


def _imported(name: str, node: ast.AST, modules: dict[str, Path]) -> set[str]:
    """The package modules that the import statement ``node`` in module ``name`` loads."""
    is_package = modules[name].name == "__init__.py"
    out: set[str] = set()
    if isinstance(node, ast.Import):
        for alias in node.names:
            if alias.name in modules:
                out.add(alias.name)
        return out
    assert isinstance(node, ast.ImportFrom)
    if node.level:
        # ``from . import x`` in a package's __init__ is relative to the package
        # itself; in a plain module, to the package that holds it.
        base = name.split(".") if is_package else name.split(".")[:-1]
        base = base[: len(base) - (node.level - 1)]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module or ""
    for alias in node.names:
        sub = f"{target}.{alias.name}"
        if sub in modules:
            out.add(sub)
        elif target in modules:
            out.add(target)
    return out


def import_graph(package: Path = PACKAGE) -> dict[str, set[str]]:
    """For every module of a package, the modules of the package it imports (anywhere in its body)."""
    modules = package_modules(package)
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(), filename=str(path))
        edges: set[str] = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                edges |= _imported(name, node, modules)
        edges.discard(name)
        graph[name] = edges
    return graph


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan 1972): each holds a cycle."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                components.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            connect(v)
    return components


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle per strongly connected component, as ``[a, b, ..., a]``."""
    return [_one_cycle(graph, set(comp)) for comp in strongly_connected(graph)]


def _one_cycle(graph: dict[str, set[str]], comp: set[str]) -> list[str]:
    """A shortest cycle through the first module of a strongly connected component (breadth first)."""
    start = min(comp)
    came_from: dict[str, str] = {}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & comp):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(came_from[path[-1]])
                    return [*reversed(path), start]
                if w not in came_from:
                    came_from[w] = v
                    nxt.append(w)
        frontier = nxt
    raise AssertionError(f"no cycle through {start} in {sorted(comp)}")


def test_the_walker_resolves_relative_absolute_and_submodule_imports(tmp_path):
    files = {
        "pkg/__init__.py": "from . import a\nfrom .sub import helper\n",
        "pkg/a.py": "from .b import X\nimport os\n\ndef f():\n    from pkg.sub import deep\n",
        "pkg/b.py": "X = 1\n\nclass C:\n    def m(self):\n        import pkg.a\n",
        "pkg/sub/__init__.py": "helper = 1\n",
        "pkg/sub/deep.py": "from .. import b\nfrom ..sub import helper\nfrom . import other\n",
        "pkg/sub/other.py": "from ..b import X as Y\n",
    }
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    graph = import_graph(tmp_path / "pkg")
    assert graph == {
        "pkg": {"pkg.a", "pkg.sub"},  # from . import a: the submodule; from .sub import helper: the package
        "pkg.a": {"pkg.b", "pkg.sub.deep"},  # a function-level absolute import counts
        "pkg.b": {"pkg.a"},  # a method-level import counts
        "pkg.sub": set(),
        "pkg.sub.deep": {"pkg.b", "pkg.sub", "pkg.sub.other"},
        "pkg.sub.other": {"pkg.b"},
    }
    assert find_cycles(graph) == [["pkg.a", "pkg.b", "pkg.a"]]


def test_the_cycle_finder_finds_a_cycle():
    assert find_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c", "a"]]
    assert find_cycles({"a": {"b"}, "b": set()}) == []


def test_the_package_has_no_import_cycle():
    graph = import_graph()
    assert "mcocl.engine.contract" in graph["mcocl.engine.dispatch"]  # the walker sees the real package
    knots = strongly_connected(graph)
    report = [f"  {' -> '.join(_one_cycle(graph, set(k)))}  (modules tied together: {', '.join(k)})" for k in knots]
    assert not knots, "import cycles in mcocl/:\n" + "\n".join(report)


def test_the_engine_back_ends_import_the_contract_and_never_each_other():
    graph = import_graph()
    back_ends = {"mcocl.engine.one_device", "mcocl.engine.multi_device", "mcocl.engine.dask_cluster"}
    for name in back_ends:
        assert {"mcocl.engine.contract", "mcocl.engine.chunking", "mcocl.engine.fold"} <= graph[name], name
        assert not graph[name] & (back_ends | {"mcocl.engine.dispatch"}), name
    importers = {name for name, edges in graph.items() if edges & back_ends}
    assert importers == {"mcocl.engine.dispatch"}
