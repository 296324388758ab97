"""The tolerance sheet of a unit type: how much each parameter may change between calibrations.

::

    format = "casadi-sins-tolerance/1"
    z_limit = 4.0              # optional: a change beyond this many combined sigma is flagged (default 4)

    [change]                   # largest change between two calibrations, natural units
    "gyro scale" = 10.0        # a group, by its label or key (ppm) ...
    gyro_bias_x = 0.005        # ... or one parameter, which overrides its group (deg/h)

    [drift_per_year]           # largest drift rate over the unit's calibrations, natural units per year
    "accel bias" = 50.0        # ug per year

    [accept.sigma]             # acceptance at calibration time: largest 1-sigma, natural units
    "gyro bias" = 0.002        # deg/h
    "accel scale" = 5.0        # ppm of the value

    [accept.value]             # largest |value| in the report's value units, or an allowed [low, high]
    "accel bias" = 500.0       # ug
    "gyro scale" = [0.99, 1.01]   # arcsec/pulse (scale factors: their pulse weight)

Natural units are those of the reports: ug, ppm (of the value), arcsec, deg/h (and mm, ms, ug/g^2
for the extra terms); values of scale factors in their pulse weight (arcsec/pulse, m/s/pulse).  A
parameter without an entry has no tolerance (neither pass nor fail).  ``[change]`` and
``[drift_per_year]`` are applied by ``history``; ``[accept.*]`` by ``calibrate --tolerance`` and
``batch --tolerance`` (:mod:`report.acceptance`).
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
#: The acceptance limits: ``[accept.sigma]`` and ``[accept.value]``.
ACCEPT_KINDS = ("sigma", "value")


@dataclasses.dataclass
class ToleranceSheet:
    """Per-parameter limits, natural units (``change``, ``drift_per_year``), and the z limit."""

    change: dict[str, float] = dataclasses.field(default_factory=dict)
    drift_per_year: dict[str, float] = dataclasses.field(default_factory=dict)
    z_limit: float = 4.0
    source: Path | None = None
    accept_sigma: dict[str, float] = dataclasses.field(default_factory=dict)
    accept_value: dict[str, tuple[float, float]] = dataclasses.field(default_factory=dict)

    @property
    def has_acceptance(self) -> bool:
        """Whether the sheet has any ``[accept.*]`` limit."""
        return bool(self.accept_sigma or self.accept_value)

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
    unknown = [k for k in doc if k not in (*KINDS, "format", "z_limit", "accept")]
    if unknown:
        raise InputError(path, f"unknown entry {shown(unknown[0])} (expected format, z_limit, [change], "
                         "[drift_per_year], [accept.sigma], [accept.value])", line=_line_of(text, unknown[0]))
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
    _read_accept(path, text, doc.get("accept", {}), sheet)
    return sheet


def _by_name(path: Path, text: str, where: str, table) -> list[tuple[str, tuple[str, ...], object]]:
    """``(key, names, value)`` of a table of limits, groups before single parameters (which override)."""
    if not isinstance(table, dict):
        raise InputError(path, f"{where} must be a table", line=_line_of(text, where.strip("[]").split(".")[-1]))
    out = []
    for key, value in sorted(table.items(), key=lambda kv: is_known(kv[0])):
        names = _names_of(key)
        if names is None:
            raise InputError(path, f"{where} {shown(key)} is neither a parameter nor a group", line=_line_of(text, key))
        out.append((key, names, value))
    return out


def _number(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def _read_accept(path: Path, text: str, accept, sheet: ToleranceSheet) -> None:
    """``[accept.sigma]`` (positive numbers) and ``[accept.value]`` (a positive bound on |value|, or ``[low,
    high]``) into the sheet."""
    if not isinstance(accept, dict):
        raise InputError(path, "accept must be the tables [accept.sigma] and [accept.value]",
                         line=_line_of(text, "accept"))
    unknown = [k for k in accept if k not in ACCEPT_KINDS]
    if unknown:
        raise InputError(path, f"unknown table [accept.{unknown[0]}] (expected [accept.sigma], [accept.value])",
                         line=_line_of(text, unknown[0]))
    for key, names, value in _by_name(path, text, "[accept.sigma]", accept.get("sigma", {})):
        if not _number(value) or value <= 0:
            raise InputError(path, f"[accept.sigma] {key} must be a positive number (natural units), found "
                             f"{shown(value)}", line=_line_of(text, key))
        sheet.accept_sigma.update({n: float(value) for n in names})
    for key, names, value in _by_name(path, text, "[accept.value]", accept.get("value", {})):
        if _number(value) and value > 0:
            bounds = (-float(value), float(value))
        elif isinstance(value, list) and len(value) == 2 and all(_number(v) for v in value) and value[0] < value[1]:
            bounds = (float(value[0]), float(value[1]))
        else:
            raise InputError(path, f"[accept.value] {key} must be a positive number (largest |value|) or [low, high] "
                             f"with low < high, natural units; found {shown(value)}", line=_line_of(text, key))
        sheet.accept_value.update({n: bounds for n in names})
