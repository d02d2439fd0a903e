"""The import picture: no import circle crosses a folder of a package.

Every ``import`` and ``from ... import`` of every module counts - at the top, inside
functions, under ``if TYPE_CHECKING`` - because each is a dependency a reader follows.
Modules of one folder may import each other in a circle (a package and its parts);
a circle through two folders ties those rooms together and is an error.
"""

from __future__ import annotations

import ast
from pathlib import Path

from rigs import ROOT


def modules(root: Path, package: str) -> dict[str, Path]:
    """Module name -> file for every ``.py`` of ``package`` (packages by ``__init__``)."""
    found = {}
    for path in sorted((root / package).rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def _imports(tree: ast.AST, module: str, is_package: bool,
             known: dict[str, Path]) -> list[str]:
    """Every module name ``module`` imports (absolute, dotted): ``from a import b``
    imports the module ``a.b`` if there is one, else ``a``."""
    here = module if is_package else module.rpartition(".")[0]
    names = []
    for node in ast.walk(tree):  # every level: functions and TYPE_CHECKING blocks too
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here.split(".")
                base = base[:len(base) - (node.level - 1)]
                origin = ".".join(base + ([node.module] if node.module else []))
            else:
                origin = node.module or ""
            for alias in node.names:
                sub = f"{origin}.{alias.name}"
                names.append(sub if sub in known else origin)
    return names


def import_graph(root: Path, package: str) -> dict[str, set[str]]:
    """Module -> the modules of ``package`` it imports (a name that is no module of
    the package counts as its longest module prefix)."""
    mods = modules(root, package)
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for name, path in mods.items():
        tree = ast.parse(path.read_text(), str(path))
        for target in _imports(tree, name, path.name == "__init__.py", mods):
            while target and target not in mods:
                target = target.rpartition(".")[0]
            if target and target != name:
                graph[name].add(target)
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def folder_of(root: Path, package: str, module: str) -> str:
    path = modules(root, package)[module]
    return str(path.parent.relative_to(root))


def folder_crossing_circles(root: Path, package: str) -> list[list[str]]:
    """The import circles of ``package`` whose modules lie in more than one folder."""
    graph = import_graph(root, package)
    return [c for c in circles(graph)
            if len({folder_of(root, package, m) for m in c}) > 1]


def crossing_path(root: Path, package: str, graph: dict[str, set[str]],
                  component: list[str]) -> list[str]:
    """A shortest circle of the component through an import between two folders (for
    the failure message): ``u -> v -> ... -> u``."""
    members = set(component)
    best: list[str] | None = None
    for u in component:
        for v in sorted(graph[u] & members):
            if folder_of(root, package, u) == folder_of(root, package, v):
                continue
            paths = {v: [u, v]}  # breadth first from v back to u
            queue = [v]
            while queue and u not in paths:
                node = queue.pop(0)
                for w in sorted(graph[node] & members):
                    if w not in paths:
                        paths[w] = paths[node] + [w]
                        queue.append(w)
            if u in paths and (best is None or len(paths[u]) < len(best)):
                best = paths[u]
    return best or component


# ------------------------------------------------------------- the checker itself
def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_a_circle_through_two_folders_is_found_also_through_function_and_typing_imports(
        tmp_path):
    _write(tmp_path, {
        "pkg/__init__.py": "",
        "pkg/core.py": "from .sub import leaf\n",
        "pkg/sub/__init__.py": "",
        "pkg/sub/leaf.py": ("from typing import TYPE_CHECKING\n"
                            "if TYPE_CHECKING:\n    from ..other import x\n"),
        "pkg/other.py": "def f():\n    import pkg.core\n",
    })
    graph = import_graph(tmp_path, "pkg")
    assert graph["pkg.core"] == {"pkg.sub.leaf"}
    assert graph["pkg.sub.leaf"] == {"pkg.other"}
    assert graph["pkg.other"] == {"pkg.core"}
    bad = folder_crossing_circles(tmp_path, "pkg")
    assert bad == [["pkg.core", "pkg.other", "pkg.sub.leaf"]]
    assert crossing_path(tmp_path, "pkg", graph, bad[0]) == [
        "pkg.core", "pkg.sub.leaf", "pkg.other", "pkg.core"]


def test_a_circle_inside_one_folder_is_allowed(tmp_path):
    _write(tmp_path, {
        "pkg/__init__.py": "from . import a\n",
        "pkg/a.py": "from .b import thing\n",
        "pkg/b.py": "from . import a\n",
        "pkg/sub/__init__.py": "",
        "pkg/sub/c.py": "from ..a import thing\n",  # one way only: no circle
    })
    assert circles(import_graph(tmp_path, "pkg")) == [["pkg.a", "pkg.b"]]
    assert folder_crossing_circles(tmp_path, "pkg") == []


# ------------------------------------------------------------------ the packages
def test_no_import_circle_crosses_a_folder_of_fas():
    graph = import_graph(ROOT, "fas")
    assert len(graph) > 50  # it did read the package
    bad = folder_crossing_circles(ROOT, "fas")
    assert not bad, "\n".join(" -> ".join(crossing_path(ROOT, "fas", graph, c))
                              for c in bad)


def test_the_core_has_no_runtime_circle_through_quickstep_or_the_backend():
    """The three runtime loops of issue 22 (backend -> quickstep.relay, stepper <->
    quickstep.setup) stay gone: the abstract backend imports no planner."""
    graph = import_graph(ROOT, "fas")
    assert not any(m.startswith("fas.quickstep") for m in graph["fas.backend"])
    assert not any(m.startswith(("fas.quickstep", "fas.stepper", "fas.engine"))
                   for m in graph["fas.channel"] | graph["fas.queue"])


def test_no_import_circle_crosses_a_folder_of_stepperdemo():
    graph = import_graph(ROOT, "stepperdemo")
    bad = folder_crossing_circles(ROOT, "stepperdemo")
    assert not bad, "\n".join(" -> ".join(crossing_path(ROOT, "stepperdemo", graph, c))
                              for c in bad)
