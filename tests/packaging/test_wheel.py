"""What ``pip install`` gives a user: the sdist and the wheel hold every module and data file of the tree.

The list is derived from the tree itself (the files git tracks under ``casadi_sins/``, or every file
there when the checkout is not a git clone), so a new module or problem file cannot be left out of a
release unnoticed.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

CHECKOUT = Path(__file__).resolve().parents[2]
PACKAGE = "casadi_sins"


def _git(*args: str, cwd: Path = CHECKOUT) -> str:
    return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=True).stdout


def _is_git_checkout() -> bool:
    try:
        return _git("rev-parse", "--show-toplevel").strip() == str(CHECKOUT)
    except (OSError, subprocess.CalledProcessError):
        return False


def package_files(tree: Path) -> set[str]:
    """The files of the package in ``tree``: what git tracks there, else every file (caches left out)."""
    if (tree / ".git").exists():
        return {f for f in _git("ls-files", PACKAGE, cwd=tree).splitlines() if not os.path.islink(tree / f)}
    return {str(p.relative_to(tree)) for p in (tree / PACKAGE).rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.name != "_build.py"}


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> tuple[Path, Path, set[str]]:
    """A copy of the checkout (its committed state when it is a git clone), built into an sdist and a wheel with
    ``python -m build``: (sdist, wheel, the package's files in the copy)."""
    work = tmp_path_factory.mktemp("build")
    tree = work / "tree"
    env = dict(os.environ)
    if _is_git_checkout():
        subprocess.run(["git", "clone", "--quiet", "--no-hardlinks", str(CHECKOUT), str(tree)], check=True)
    else:  # an unpacked source tree: no history, so the version cannot come from git
        shutil.copytree(CHECKOUT, tree, ignore=shutil.ignore_patterns("__pycache__", "build", "dist", "*.egg-info",
                                                                        "site", ".pytest_cache"))
        env["SETUPTOOLS_SCM_PRETEND_VERSION"] = "0+unknown"
    done = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(work / "dist"), str(tree)],
                          capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    (sdist,) = (work / "dist").glob("*.tar.gz")
    (wheel,) = (work / "dist").glob("*.whl")
    return sdist, wheel, package_files(tree)


def test_the_wheel_holds_every_module_and_data_file_of_the_package(built):
    _, wheel, expected = built
    assert any(f.endswith(".toml") for f in expected) and any(f.endswith(".py") for f in expected)
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = sorted(expected - names)
    assert not missing, f"the wheel lacks {missing[:20]}"
    assert f"{PACKAGE}/core/_build.py" in names  # the build's identity


def test_the_sdist_holds_every_file_of_the_package_and_the_project(built):
    sdist, _, expected = built
    with tarfile.open(sdist) as archive:
        names = {name.split("/", 1)[1] for name in archive.getnames() if "/" in name}
    missing = sorted(expected - names)
    assert not missing, f"the sdist lacks {missing[:20]}"
    assert {"pyproject.toml", "README.md", "LICENSE"} <= names


def test_twine_accepts_both_distributions(built):
    sdist, wheel, _ = built
    done = subprocess.run([sys.executable, "-m", "twine", "check", "--strict", str(sdist), str(wheel)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_wheel_is_named_by_the_commit_it_was_built_from(built):
    """A build from a git clone carries its commit (setuptools-scm), which ``--version`` prints."""
    if not _is_git_checkout():
        pytest.skip("not a git clone: no commit to name")
    _, wheel, _ = built
    text = zipfile.ZipFile(wheel).read(f"{PACKAGE}/core/_build.py").decode()
    assert _git("rev-parse", "HEAD").strip()[:12] in text
