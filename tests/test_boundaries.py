"""Package boundaries of the design: data flows pipeline -> planner -> console, never back."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _imports(package: str) -> dict[str, set[str]]:
    """Absolute modules imported by each file of a package (relative imports resolved)."""
    out: dict[str, set[str]] = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        mod_parts = path.relative_to(ROOT).with_suffix("").parts
        names: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = mod_parts[: len(mod_parts) - node.level]
                    names.add(".".join(base + ((node.module,) if node.module else ())))
                elif node.module:
                    names.add(node.module)
        out[str(path.relative_to(ROOT))] = names
    return out


@pytest.mark.parametrize("package, forbidden", [("pipeline", ("planner", "console")), ("assets", ("pipeline", "planner", "console"))])
def test_lower_packages_do_not_import_higher_ones(package: str, forbidden: tuple[str, ...]) -> None:
    bad = {f: sorted(m for m in mods if m.split(".")[0] in forbidden) for f, mods in _imports(package).items()}
    assert not {f: m for f, m in bad.items() if m}


def test_planner_imports_only_the_scene_from_pipeline() -> None:
    for f, mods in _imports("planner").items():
        assert not any(m.split(".")[0] == "console" for m in mods), f
        assert all(m == "pipeline.scene" for m in mods if m.split(".")[0] == "pipeline"), (f, mods)
