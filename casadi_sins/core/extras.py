"""The optional extras of the package, and the one message that says how to install a missing one."""

from __future__ import annotations

from .text import one_line


def missing_extra(feature: str, extra: str, library: str, exc: BaseException | None = None) -> str:
    """The one line for a feature whose optional library is missing: both ways to install the extra, from the
    package index (``pip install "casadi-sins[hdf5]"``) and from a checkout of the source (``pip install
    ".[hdf5]"``).  ``exc``, the import's own error, is named when it is not a plain absence (a library that
    is there but cannot load what it needs)."""
    cause = "" if exc is None or isinstance(exc, ImportError) else f" ({one_line(exc, 160)})"
    return (f"{feature} needs {library}{cause}: install the extra '{extra}' with pip install "
            f"\"casadi-sins[{extra}]\" (from a checkout of the source: pip install \".[{extra}]\")")
