"""The tolerance sheet of a unit type: how much each parameter may change between calibrations.

::

    format = "casadi-sins-tolerance/1"
    z_limit = 4.0              # optional: a change beyond this many combined sigma is flagged (default 4)

    [change]                   # largest change between two calibrations, natural units
    "gyro scale" = 10.0        # a group, by its label or key (ppm) ...
    gyro_bias_x = 0.005        # ... or one parameter, which overrides its group (deg/h)

    [drift_per_year]           # largest drift rate over the unit's calibrations, natural units per year
    "accel bias" = 50.0        # ug per year

Natural units are those of the reports: ug, ppm (of the value), arcsec, deg/h (and mm, ms, ug/g^2
for the extra terms).  A parameter without an entry has no tolerance (neither pass nor fail).
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

from ..core.errors import InputError, shown
from ..core.toml import read_toml_text
from ..model.registry import GROUPS, is_known

FORMAT = "casadi-sins-tolerance/1"
KINDS = ("change", "drift_per_year")


@dataclasses.dataclass
class ToleranceSheet:
    """Per-parameter limits, natural units (``change``, ``drift_per_year``), and the z limit."""

    change: dict[str, float] = dataclasses.field(default_factory=dict)
    drift_per_year: dict[str, float] = dataclasses.field(default_factory=dict)
    z_limit: float = 4.0
    source: Path | None = None

    def limit(self, kind: str, name: str) -> float:
        """The limit of one kind for a parameter (NaN when the sheet has none)."""
        return getattr(self, kind).get(name, math.nan)


def _line_of(text: str, key: str) -> int | None:
    match = re.search(rf'^\s*"?{re.escape(key)}"?\s*=', text, re.MULTILINE)
    return text.count("\n", 0, match.start()) + 1 if match else None


def _names_of(key: str) -> tuple[str, ...] | None:
    if is_known(key):
        return (key,)
    for group in GROUPS.values():
        if key in (group.key, group.label):
            return group.names
    return None


def read_tolerance_sheet(path: str | Path) -> ToleranceSheet:
    """Read a tolerance sheet (see the module docstring).

    Raises
    ------
    InputError
        Naming the file and line of an unknown name, a limit that is not a positive number, or an
        unknown table.
    """
    path = Path(path)
    doc, text = read_toml_text(path, "tolerance sheet")
    fmt = doc.get("format", FORMAT)
    if fmt != FORMAT:
        raise InputError(path, f"format must be {FORMAT!r}, found {shown(fmt)}", line=_line_of(text, "format"))
    unknown = [k for k in doc if k not in (*KINDS, "format", "z_limit")]
    if unknown:
        raise InputError(path, f"unknown entry {shown(unknown[0])} (expected format, z_limit, [change], "
                         "[drift_per_year])", line=_line_of(text, unknown[0]))
    z_limit = doc.get("z_limit", 4.0)
    if isinstance(z_limit, bool) or not isinstance(z_limit, (int, float)) or not z_limit > 0:
        raise InputError(path, f"z_limit must be a positive number, found {shown(z_limit)}",
                         line=_line_of(text, "z_limit"))
    sheet = ToleranceSheet(z_limit=float(z_limit), source=path)
    for kind in KINDS:
        table = doc.get(kind, {})
        if not isinstance(table, dict):
            raise InputError(path, f"{kind} must be a table [{kind}]", line=_line_of(text, kind))
        groups = {k: v for k, v in table.items() if not is_known(k)}
        singles = {k: v for k, v in table.items() if is_known(k)}
        for key, value in [*groups.items(), *singles.items()]:  # a parameter overrides its group
            names = _names_of(key)
            if names is None:
                raise InputError(path, f"[{kind}] {shown(key)} is neither a parameter nor a group",
                                 line=_line_of(text, key))
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value <= 0:
                raise InputError(path, f"[{kind}] {key} must be a positive number (natural units), found "
                                 f"{shown(value)}", line=_line_of(text, key))
            getattr(sheet, kind).update({n: float(value) for n in names})
    return sheet
