"""The suite tests what users install, and the installed command works from any folder.

``.ci/run`` (the README's test command) installs the package non-editable and runs the suite through
the ``pytest`` console script in importlib mode: the package is then imported from the installed
copy, never from the working tree. These tests fail when that is not so, and run the installed
``casadi-sins`` from a folder outside the checkout, as a user would.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

import casadi_sins

CHECKOUT = Path(__file__).resolve().parents[2]


def _editable() -> bool:
    """True for an editable (development) install: the suite then tests the working tree, knowingly."""
    for dist in metadata.distributions(name="casadi-sins"):
        direct = dist.read_text("direct_url.json")
        if direct and json.loads(direct).get("dir_info", {}).get("editable"):
            return True
    return False


def console_script() -> str:
    """The installed ``casadi-sins`` command (beside this Python, else on the PATH)."""
    beside = Path(sys.executable).parent / "casadi-sins"
    found = str(beside) if beside.exists() else shutil.which("casadi-sins")
    assert found, "casadi-sins is not installed: pip install the checkout first (see the README)"
    return found


def test_the_suite_runs_on_the_installed_package_not_the_checkout():
    if _editable():
        pytest.skip("editable install: the working tree is the installed package (CI installs the wheel)")
    here = Path(casadi_sins.__file__).resolve()
    assert CHECKOUT not in here.parents, (
        f"casadi_sins was imported from the checkout ({here}), not from the installed package: run the suite "
        "as the README says (pip install \".[test]\" && pytest)")


def test_the_installed_package_is_the_distribution_of_this_version():
    assert metadata.version("casadi-sins") == casadi_sins.__version__


@pytest.fixture(scope="module")
def outside(tmp_path_factory) -> Path:
    """A working folder outside the checkout."""
    folder = tmp_path_factory.mktemp("user")
    assert CHECKOUT not in folder.resolve().parents
    return folder


def test_every_subcommand_prints_its_help_from_any_folder(outside):
    from casadi_sins.cli.parser import build_parser

    (sub,) = [a for a in build_parser()._actions if a.dest == "command"]
    commands = sorted(sub.choices)
    assert {"calibrate", "demo", "simulate", "batch"} <= set(commands)
    procs = {c: subprocess.Popen([console_script(), c, "--help"], cwd=outside, stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True) for c in commands}
    procs[""] = subprocess.Popen([console_script(), "--help"], cwd=outside, stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True)
    for command, proc in procs.items():
        out, err = proc.communicate(timeout=120)
        assert proc.returncode == 0 and not err, (command, err)
        assert out.startswith("usage: casadi-sins" + (f" {command}" if command else "")), (command, out[:200])


def test_the_demo_runs_from_any_folder_and_writes_all_its_outputs(outside):
    """The README's first command, run where a user stands: both solvers' tables, their comparison, the
    navigation check and the error budget, from the simulated recording it keeps."""
    done = subprocess.run([console_script(), "demo", "--out", "D", "--quiet"], cwd=outside, capture_output=True,
                          text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    out = outside / "D"
    stem = "kang2013-seed1"
    for name in ["nlp.csv", "ils.csv", "compare.md", "compare-residuals.png", "navcheck.md", "navcheck.png",
                 "budget.md", "budget.png"]:
        assert (out / f"{stem}-{name}").stat().st_size > 0, name
    assert {p.suffix for p in (out / "recordings").iterdir()} >= {".toml", ".csv"}
    from casadi_sins import read_table

    for solver in ("nlp", "ils"):
        assert len(read_table(out / f"{stem}-{solver}.csv").values) >= 21


def test_version_names_the_build(outside):
    done = subprocess.run([console_script(), "--version"], cwd=outside, capture_output=True, text=True)
    assert done.returncode == 0 and "\n" not in done.stdout.strip()
    assert done.stdout.startswith(f"casadi-sins {casadi_sins.__version__}")
    if (CHECKOUT / ".git").exists() and not _editable():  # installed from this clone: its commit
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=CHECKOUT, capture_output=True, text=True).stdout
        assert f"commit {head.strip()[:12]}" in done.stdout, done.stdout
    assert os.environ.get("PYTHONSAFEPATH") == "1"  # child Pythons do not import the checkout (conftest)
