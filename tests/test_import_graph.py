"""No import circles in explorer: the graph of which module imports which (every ``import`` statement, at the
top of a module or inside a function, outside ``if TYPE_CHECKING``) has no cycle, so no two files import
each other, directly or in a loop; and the pipeline's packages import one way (mechanism -> plan -> kernels
-> wrist -> gait -> store -> study -> analysis -> synthesis -> optimize -> fabrication -> view -> cli); and
every name that moved to another room (issue 40) is still importable from its old package, as the very
object at its new home."""

from __future__ import annotations

import ast
from pathlib import Path

import explorer

ROOT = Path(explorer.__file__).parent


def _modules() -> dict[str, Path]:
    out = {}
    for f in ROOT.rglob("*.py"):
        parts = list(f.relative_to(ROOT.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = f
    return out


def _imports(name: str, path: Path, modules) -> set[str]:
    """The explorer modules ``name`` imports anywhere in its body (a package's ``__init__`` counts as the
    package; ``from .pkg import sub`` as the submodule)."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()

    def visit(nodes):
        for node in nodes:
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                visit(node.orelse)
                continue
            if isinstance(node, ast.ImportFrom):
                base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else [])) \
                    if node.level else (node.module or "")
                for alias in node.names:
                    sub = f"{base}.{alias.name}"
                    found.add(sub if sub in modules else base)
            elif isinstance(node, ast.Import):
                found.update(alias.name for alias in node.names)
            visit(ast.iter_child_nodes(node))

    visit(ast.parse(path.read_text(encoding="utf-8")).body)
    return {m for m in found if m in modules and m != name}


def import_graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module, each a loop of imports (the plan's
    Tarjan, :func:`explorer.testing.strong_components`)."""
    from explorer.testing import strong_components
    names = sorted(graph)
    at = {n: i for i, n in enumerate(names)}
    comps = strong_components([sorted(at[d] for d in graph[n] if d in at) for n in names])
    return [sorted(names[i] for i in c) for c in comps if len(c) > 1]


def test_the_checker_finds_a_loop():
    """The cycle finder itself: a loop of three, a pair, and a chain that is no loop."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"e"}, "e": {"d"}, "f": {"a"}, "g": set()}
    assert sorted(cycles(graph)) == [["a", "b", "c"], ["d", "e"]]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_the_graph_sees_lazy_and_relative_imports():
    """The graph is read right: a function-level import counts (the issue's circles were lazy ones), and
    relative imports resolve to the module."""
    graph = import_graph()
    assert "explorer.study._chunk" in graph["explorer.study._run"]  # top level, relative
    assert "explorer.fabrication._kit_sheet" in graph["explorer.fabrication._kit"]
    assert "explorer.gait" in graph["explorer.study._spec"]


def test_no_import_cycles():
    found = cycles(import_graph())
    assert not found, "modules that import each other, directly or in a loop: " + "; ".join(
        " <-> ".join(c) for c in found)


PIPELINE = ("mechanism", "plan", "kernels", "wrist", "gait", "store", "study", "analysis", "synthesis", "optimize",
            "fabrication", "view", "cli")


def test_packages_import_one_way():
    """No package of the pipeline imports one later in it (mechanism -> plan -> ... -> cli)."""
    graph = import_graph()
    back = []
    for name, deps in graph.items():
        parts = name.split(".")
        if len(parts) < 2 or parts[1] not in PIPELINE:
            continue
        here = PIPELINE.index(parts[1])
        for dep in deps:
            d = dep.split(".")
            if len(d) > 1 and d[1] in PIPELINE and PIPELINE.index(d[1]) > here:
                back.append(f"{name} -> {dep}")
    assert not back, "imports running back up the pipeline: " + ", ".join(sorted(back))


def test_moved_names_still_import_from_their_old_package():
    """Each name in explorer._moved.MOVED: the old spelling warns and gives the new home's object."""
    import importlib
    import warnings

    from explorer.testing import MOVED
    for package in ("explorer.kernels", "explorer.store", "explorer.study", "explorer.view"):
        importlib.import_module(package)
    assert MOVED, "no moved names registered"
    for package, names in MOVED.items():
        old = importlib.import_module(package)
        for name, home in names.items():
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                value = getattr(old, name)
            assert value is getattr(importlib.import_module(home), name), f"{package}.{name}"
            assert any(issubclass(w.category, DeprecationWarning) and home in str(w.message) for w in caught)


def test_store_does_not_import_the_kernels():
    """store reads and writes files only (issue 40): no module of it imports explorer.kernels, anywhere in its
    body, and importing it loads no kernel; a lean file's re-solve and a variant's assembly are study's
    (explorer.study.resolve_series, through the resolver store is given). The status codes it stores are the
    kernels' (its own table, held equal to theirs here)."""
    import subprocess
    import sys

    from explorer.kernels import STATUS_NAMES
    from explorer.store import FILE_STATUS_NAMES, STATUS_NOT_RUN
    graph = import_graph()
    store = [n for n in graph if n == "explorer.store" or n.startswith("explorer.store.")]
    assert "explorer.store._read" in store and "explorer.store._write" in store
    bad = sorted(f"{n} -> {d}" for n in store for d in graph[n] if d.split(".")[:2] == ["explorer", "kernels"])
    assert not bad, "store imports the kernels: " + ", ".join(bad)
    run = subprocess.run([sys.executable, "-c", "import sys, explorer.store; "
                          "print(sorted(m for m in sys.modules if m.startswith('explorer.kernels')))"],
                         capture_output=True, text=True, check=True)
    assert run.stdout.strip() == "[]", run.stdout
    assert FILE_STATUS_NAMES == {**{int(k): v for k, v in STATUS_NAMES.items()}, STATUS_NOT_RUN: "not-run"}


def test_the_upper_floors_open_results_with_the_re_solver():
    """Packages above study open results files through explorer.study.open_results (store's, with
    explorer's re-solver), so store's by-name fallback (store._resolver.RESOLVER_HOME) serves only a
    program that calls explorer.store.open_results itself."""
    import ast
    above = PIPELINE[PIPELINE.index("study") + 1:] + ("edit", "physics")
    found = []
    for pkg in above:
        for f in sorted((ROOT / pkg).glob("*.py")):
            for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
                if isinstance(node, ast.ImportFrom) and node.module in ("store", "explorer.store") and \
                        any(a.name == "open_results" for a in node.names):
                    found.append(f"{pkg}/{f.name}:{node.lineno}")
    assert not found, found
