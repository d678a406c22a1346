"""No import circles and no module over 500 lines in the product's packages.

Every import counts: at module level, inside functions (deferred imports) and under ``TYPE_CHECKING``.
An import of ``a.b`` counts as an edge to ``a.b`` (a package's ``__init__`` when ``a.b`` is a package);
``from a import b`` counts as an edge to the module ``a.b`` when there is one, else to ``a``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("console", "pipeline", "planner", "assets")
MAX_LINES = 500


def _modules(root: Path) -> dict[str, tuple[Path, tuple[str, ...]]]:
    """Module name -> (file, the package it lives in)."""
    out: dict[str, tuple[Path, tuple[str, ...]]] = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
                out[".".join(parts)] = (path, parts)
            else:
                out[".".join(parts)] = (path, parts[:-1])
    return out


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the product modules it imports (every import statement, wherever it stands)."""
    mods = _modules(root)

    def resolve(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {}
    for name, (path, package) in mods.items():
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                deps.update(r for a in node.names if (r := resolve(a.name)))
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package[: len(package) - node.level + 1]
                    full = ".".join(base + ((node.module,) if node.module else ()))
                else:
                    full = node.module or ""
                for a in node.names:
                    target = f"{full}.{a.name}"
                    r = target if target in mods else resolve(full)
                    if r:
                        deps.add(r)
        deps.discard(name)
        graph[name] = deps
    return graph


def import_circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (each is at least one circle), sorted."""
    names = sorted(graph)
    index = {n: i for i, n in enumerate(names)}
    rows = [index[a] for a in names for b in graph[a]]
    cols = [index[b] for a in names for b in graph[a]]
    matrix = csr_matrix(([1] * len(rows), (rows, cols)), shape=(len(names), len(names)))
    _, labels = connected_components(matrix, directed=True, connection="strong")
    groups: dict[int, list[str]] = {}
    for n, label in zip(names, labels):
        groups.setdefault(int(label), []).append(n)
    return sorted(g for g in groups.values() if len(g) > 1)


def test_the_checker_finds_a_circle_through_a_deferred_import(tmp_path: Path) -> None:
    pkg = tmp_path / "pipeline"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from pipeline.b import f\n")
    (pkg / "b.py").write_text("def f():\n    from . import a\n")
    (pkg / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pipeline import b\n")
    for name in ("console", "planner", "assets"):
        (tmp_path / name).mkdir()
    graph = import_graph(tmp_path)
    assert graph["pipeline.c"] == {"pipeline.b"}
    assert import_circles(graph) == [["pipeline.a", "pipeline.b"]]


def test_no_import_circles() -> None:
    graph = import_graph()
    circles = import_circles(graph)
    detail = {m: sorted(d for d in graph[m] if d in group) for group in circles for m in group}
    assert not circles, f"import circles (module -> the modules of its circle it imports): {detail}"


@pytest.mark.parametrize("package", PACKAGES)
def test_no_module_over_500_lines(package: str) -> None:
    long = {str(p.relative_to(ROOT)): n for p in sorted((ROOT / package).rglob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines (split them by concern): {long}"
