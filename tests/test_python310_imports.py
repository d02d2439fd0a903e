"""Python 3.10 (issue 26, item 11): ``tomllib`` is new in 3.11, so every import of it in
the shipped packages sits behind a ``sys.version_info`` check with ``tomli`` in the
other branch.  A bare ``import tomllib`` ran fine on 3.11+ and ended
``stepperdemo gcode FILE.toml`` in a ModuleNotFoundError traceback on 3.10."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
NEW_IN_311 = {"tomllib"}


def unguarded_imports(path: Path) -> list[str]:
    """``file:line`` of each import of a 3.11-only module not under a version check."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    parents: dict[ast.AST, ast.AST] = {}
    for node in ast.walk(tree):
        for child in ast.iter_child_nodes(node):
            parents[child] = node
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = {node.module.split(".")[0]}
        else:
            continue
        if not names & NEW_IN_311:
            continue
        up = parents.get(node)
        while up is not None and not (isinstance(up, ast.If)
                                      and "version_info" in ast.unparse(up.test)):
            up = parents.get(up)
        if up is None:
            where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path.name
            found.append(f"{where}:{node.lineno}")
    return found


def test_modules_new_in_python_3_11_are_imported_behind_a_version_check() -> None:
    files = [p for package in ("fas", "stepperdemo") for p in (ROOT / package).rglob("*.py")]
    assert len(files) > 100
    assert [where for p in sorted(files) for where in unguarded_imports(p)] == []


def test_the_check_sees_a_bare_import(tmp_path: Path) -> None:
    bare = tmp_path / "probe.py"
    bare.write_text("def f():\n    import tomllib\n    return tomllib\n")
    assert unguarded_imports(bare) == ["probe.py:2"]
    bare.write_text("import sys\nif sys.version_info >= (3, 11):\n    import tomllib\n"
                    "else:\n    import tomli as tomllib\n")
    assert unguarded_imports(bare) == []
