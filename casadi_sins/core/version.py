"""The package version, and the versions of what computed a result, written into reports and exports."""

from __future__ import annotations

import functools
import platform

__version__ = "0.2.0"


@functools.lru_cache(maxsize=None)
def software_versions() -> dict[str, str]:
    """Versions of casadi-sins, CasADi, its Ipopt plugin, NumPy and Python, for provenance.

    Ipopt's version is read from the name of the library CasADi ships (``libipopt.so.3.14.19``);
    when no such file is found the entry says so instead of guessing.
    """
    import casadi
    import numpy

    return {"casadi-sins": __version__, "casadi": casadi.__version__, "ipopt": _ipopt_version(casadi),
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
