"""The package's rules for the modulation code: short modules and functions, a docstring on every public
name, imports only downward (a study may use everything but the command line), and the packaging."""

import ast
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
MODULES = sorted((ROOT / "casadi_sins" / "studies" / "modulation").glob("*.py")) + [
    ROOT / "casadi_sins" / "cli" / "modulation.py"]
#: Subpackages a study may import (core < model < data < nav < noise < calibrate < report < studies; sim).
BELOW_CLI = {"core", "model", "data", "nav", "noise", "calibrate", "report", "studies", "sim"}


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_short_modules_and_functions_with_docstrings(path):
    text = path.read_text()
    tree = ast.parse(text)
    assert len(text.splitlines()) <= 400
    assert ast.get_docstring(tree)
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            assert node.end_lineno - node.lineno < 80, node.name
            if not node.name.startswith("_"):
                assert ast.get_docstring(node), f"{path.name}: {node.name} has no docstring"


@pytest.mark.parametrize("path", MODULES[:-1], ids=lambda p: p.name)
def test_the_study_imports_only_downward(path):
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 3:  # from ...X import: casadi_sins.X
            assert node.module.split(".")[0] in BELOW_CLI, node.module
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            assert not (node.module or "").startswith("casadi_sins"), node.module


def test_the_subpackage_and_the_shipped_schemes_are_packaged():
    """The packages setuptools finds with the project's ``include`` hold the study and the shipped schemes
    (their TOML files come with the package as data, from git)."""
    from setuptools import find_packages

    find = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]
    found = set(find_packages(str(ROOT), include=find["include"]))
    assert {"casadi_sins.studies.modulation", "casadi_sins.problems.schemes"} <= found
    assert any((ROOT / "casadi_sins" / "problems" / "schemes").glob("*.toml"))
