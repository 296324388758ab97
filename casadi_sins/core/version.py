"""The package version, and the versions of what computed a result, written into reports and exports."""

from __future__ import annotations

import functools
import platform


def _build_identity() -> tuple[str, str | None, str | None]:
    """(version, commit, commit date) of this build.

    setuptools-scm writes ``casadi_sins/core/_build.py`` when the package is built or installed (from the
    git tag ``vX.Y.Z`` and the commit); a source tree that was never built has no such file and reads
    ``unknown``.
    """
    try:
        from . import _build
    except ImportError:
        return "unknown (not built: pip install the checkout)", None, None
    commit = _build.__commit__ if _build.__commit__ not in ("None", "") else None
    if commit and commit.startswith("g"):
        commit = commit[1:]
    commit = commit[:12] if commit else None
    if commit and _build.__dirty__:
        commit += " with uncommitted changes"
    date = _build.__commit_date__ if _build.__commit_date__ not in ("None", "") else None
    return _build.__version__, commit, date


__version__, __commit__, __commit_date__ = _build_identity()


def build_identity() -> str:
    """One line naming this build: ``casadi-sins 0.3.0 (commit 1a2b3c4, 2026-11-27)``."""
    details = ", ".join(x for x in (f"commit {__commit__}" if __commit__ else None, __commit_date__) if x)
    return f"casadi-sins {__version__}" + (f" ({details})" if details else "")


@functools.lru_cache(maxsize=None)
def software_versions() -> dict[str, str]:
    """Versions of casadi-sins, CasADi, its Ipopt plugin, NumPy and Python, for provenance.

    Ipopt's version is read from the name of the library CasADi ships (``libipopt.so.3.14.19``);
    when no such file is found the entry says so instead of guessing.
    """
    import casadi
    import numpy

    return {"casadi-sins": __version__, "casadi-sins commit": __commit__ or "unknown", "casadi": casadi.__version__, "ipopt": _ipopt_version(casadi),
            "numpy": numpy.__version__, "python": platform.python_version()}


def _ipopt_version(casadi) -> str:
    import re
    from pathlib import Path

    versions = []
    for path in Path(casadi.__file__).parent.glob("*ipopt*"):
        match = re.match(r"^(?:lib)?ipopt\.(?:so\.)?(\d+\.\d+\.\d+)", path.name)  # .so.3.14.19, .3.14.19.dylib
        if match:
            versions.append(match.group(1))
    if versions:
        return max(versions, key=lambda v: tuple(int(x) for x in v.split(".")))
    plugin = "found" if any(Path(casadi.__file__).parent.glob("*nlpsol_ipopt*")) else "not found"
    return f"unknown (CasADi's Ipopt plugin {plugin}; its library carries no version in its name)"
