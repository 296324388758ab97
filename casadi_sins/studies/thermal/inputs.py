"""The calibrations of a thermal fit: each table, its full covariance and its temperature.

A table ``NAME.csv`` (``parameter,unit,value,sigma``, :func:`data.tables.read_table`) brings its full
covariance in the companion report ``NAME.report.json`` that ``calibrate`` and ``batch`` write beside
it (key ``"covariance"``, SI, table order; read as its record, :mod:`data.record`); without one the sigma column alone weighs it (said in a
note).  Its temperature, first found of:

1. given on the command line, ``NAME.csv@25`` (degC) or one ``--temperatures`` entry per table;
2. the report's ``"conditions": {"temperature_c": ...}``: the recording's ``[conditions]
   temperature_c``, or the mean of its ``temperature`` column over the rests, as ``calibrate`` found it.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ...core.errors import InputError, shown
from ...core.text import decimal_number
from ...data.conditions import TEMPERATURE_RANGE_C
from ...data.record import read_record
from ...model.parameters import ParameterSet
from .fit import Point

_AT = re.compile(r"^(?P<path>.+)@(?P<t>[-+0-9.eE ]*)$")


def split_spec(spec: str) -> tuple[str, float | None]:
    """``"NAME.csv@25"`` -> ``("NAME.csv", 25.0)``; a plain path (or an existing file with an ``@``) ->
    ``(path, None)``.

    Raises
    ------
    InputError
        For text after the ``@`` that is not a decimal number of degC (``NAME.csv@.``, ``NAME.csv@1.2.3``).
    """
    match = _AT.match(spec)
    if not match or Path(spec).exists():
        return spec, None
    try:
        return match["path"], decimal_number(match["t"])
    except ValueError:
        raise InputError(match["path"], f"{shown(spec)}: the temperature after '@' must be a number of degC, as in "
                         f"{match['path']}@25") from None


def load_point(spec: str, temperature_c: float | None = None) -> tuple[Point, list[str]]:
    """One calibration: its table with covariance and its temperature; notes on what is missing.

    Raises
    ------
    InputError
        Naming the table without a temperature, without sigma, or with a covariance that is not its own.
    """
    path_text, given = split_spec(spec)
    path = Path(path_text)
    record = read_record(path)
    params, origin = record.table_parameters, record.provenance
    notes = []
    temperature = given if given is not None else temperature_c
    if temperature is None:
        temperature = record.temperature_c
    if temperature is None:
        raise InputError(path, "no temperature: its report has no conditions.temperature_c; give it as "
                         f"{path_text}@TEMP or with --temperatures")
    low, high = TEMPERATURE_RANGE_C
    if not low <= temperature <= high:
        raise InputError(path, f"temperature {temperature:g} degC is outside {low:g}..{high:g} degC (a typo? Kelvin?)")
    if params.sigma is None or np.any(~np.isfinite(params.sigma)):
        raise InputError(path, "no sigma for every parameter: a thermal fit weighs each calibration by it")
    if record.covariance is not None:  # checked against the table by the record
        params = record.parameters
    else:
        notes.append(f"{path}: no covariance in a companion report; its sigma column alone weighs it "
                     "(correlations between its parameters unknown)")
    return Point(float(temperature), params, str(path), _origin(origin)), notes


def load_points(specs: list[str], temperatures: list[float] | None = None
                ) -> tuple[list[Point], list[str], str | None]:
    """Every calibration (:func:`load_point`), on the parameters they share, ordered by temperature;
    notes; the unit id their reports name (None when none does).

    Raises
    ------
    InputError
        For fewer than two tables, a ``--temperatures`` list of another length, or tables without
        common parameters.
    """
    if len(specs) < 2:
        raise InputError(None, "thermal needs at least two parameter tables (one per temperature)")
    if temperatures is not None and len(temperatures) != len(specs):
        raise InputError(None, f"--temperatures has {len(temperatures)} entries for {len(specs)} tables")
    points, notes = [], []
    for k, spec in enumerate(specs):
        point, more = load_point(spec, None if temperatures is None else temperatures[k])
        points.append(point)
        notes += more
    seen: dict[str, str] = {}
    for p in points:
        for key in (str(Path(p.label).resolve()), p.origin["recording_sha256"]):
            if key and key in seen:
                raise InputError(p.label, f"the same calibration as {seen[key]} (same table or recording): a thermal "
                                 "fit needs independent calibrations")
            if key:
                seen[key] = p.label
    units = {p.origin["unit_id"] for p in points} - {None}
    if len(units) > 1:
        raise InputError(None, f"the tables are of units {', '.join(sorted(units))}: a thermal model is of one unit")
    names = [n for n in points[0].params.names if all(n in p.params.names for p in points)]
    dropped = sorted({n for p in points for n in p.params.names} - set(names))
    if dropped:
        notes.append(f"parameters not in every table left out: {', '.join(dropped)}")
    points = [Point(p.temperature_c, _subset(p.params, names), p.label,
                    {k: v for k, v in p.origin.items() if k != "unit_id"}) for p in points]
    points.sort(key=lambda p: p.temperature_c)
    return points, notes, next(iter(units), None)


def _origin(origin) -> dict:
    """What the thermal model keeps of a calibration's provenance (:class:`data.record.Provenance`), and its unit."""
    return {"table_sha256": origin.table_sha256, "recording_sha256": origin.recording_sha256,
            "calibrated": origin.date.isoformat(timespec="seconds") if origin.from_report else None,
            "calibrated_with": origin.software, "unit_id": origin.unit_id}


def _subset(params: ParameterSet, names: list[str]) -> ParameterSet:
    idx = [params.names.index(n) for n in names]
    if params.covariance is not None:
        return ParameterSet(params.values[idx], covariance=params.covariance[np.ix_(idx, idx)], names=names)
    return ParameterSet(params.values[idx], sigma=params.sigma[idx], names=names)
