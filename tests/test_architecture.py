"""The floors of docs/architecture.md: every module imports only from its own floor or below, so the
package has no import loop and no arrow back up."""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "casadi_sins"
FLOORS = {"core": 1, "model": 2, "data": 3, "nav": 4, "sim": 4, "noise": 5, "calibrate": 6, "report": 7,
          "studies": 8, "cli": 9}
MODULES = sorted(p for p in PACKAGE.rglob("*.py") if p.relative_to(PACKAGE).parts[0] in FLOORS)


def _imported_subpackages(path: Path) -> set[str]:
    """The top-level subpackages of ``casadi_sins`` a module imports (relative or absolute imports)."""
    depth = len(path.relative_to(PACKAGE).parts) - 1  # folders below casadi_sins
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                parts = path.relative_to(PACKAGE).parts[:depth - node.level + 1] + tuple((node.module or "").split("."))
            elif (node.module or "").startswith("casadi_sins."):
                parts = tuple(node.module.split(".")[1:])
            else:
                continue
            parts = [p for p in parts if p]
            if parts:
                out.add(parts[0])
        elif isinstance(node, ast.Import):
            out.update(a.name.split(".")[1] for a in node.names if a.name.startswith("casadi_sins."))
    return out


def test_every_subpackage_has_a_floor_and_a_page():
    subpackages = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()} - {"problems"}
    assert subpackages == set(FLOORS)
    text = (PACKAGE.parent / "docs" / "architecture.md").read_text()
    for name, floor in FLOORS.items():
        assert f"| {floor} | `{name}` |" in text, name


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_go_only_down(path):
    own = FLOORS[path.relative_to(PACKAGE).parts[0]]
    for sub in _imported_subpackages(path):
        if sub in FLOORS:
            assert FLOORS[sub] <= own, f"{path.relative_to(PACKAGE)} imports {sub} (floor {FLOORS[sub]} > {own})"
