"""The thermal model file: ``thermal.csv`` and its companion ``thermal.json`` (the full covariance).

``thermal.csv``, one row per parameter (:class:`model.thermal.ThermalModel`)::

    parameter,unit,p_ref,p_ref_sigma,a1,a1_sigma,a2,a2_sigma,order,reference_c,min_c,max_c

``unit`` is the parameter's unit (SI as written; any known unit of the same dimension is read),
``a1`` is in that unit per degC and ``a2`` per degC^2; ``reference_c`` is ``T_ref`` and ``min_c`` ..
``max_c`` the calibrated range (the same on every row).  The companion ``NAME.json`` beside
``NAME.csv`` (format ``casadi-sins-thermal/1``) holds the covariance of all coefficients (SI, the
order of :class:`ThermalModel`); without it the model is read with the sigma columns alone
(correlations unknown).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ..core.errors import InputError, shown
from ..core.inputs import check_input_file, first_line
from ..core.units import TO_SI, dimension_of
from ..model.registry import is_known, unit_of
from ..model.thermal import ThermalModel

FORMAT = "casadi-sins-thermal/1"
COLUMNS = ("parameter", "unit", "p_ref", "p_ref_sigma", "a1", "a1_sigma", "a2", "a2_sigma", "order",
           "reference_c", "min_c", "max_c")
MAX_BYTES = 20_000_000


def companion_path(csv_path: str | Path) -> Path:
    """``NAME.json`` beside ``NAME.csv``."""
    return Path(csv_path).with_suffix(".json")


def read_companion(csv_path: str | Path) -> object | None:
    """The companion ``NAME.json`` of a thermal model ``NAME.csv`` as parsed JSON, None when there is none.

    Raises
    ------
    InputError
        Naming the companion when it is not a regular readable file, too large, or not JSON.
    """
    companion = companion_path(csv_path)
    if not (companion.exists() or companion.is_symlink()):
        return None
    check_input_file(companion, "thermal model companion", MAX_BYTES)
    try:
        return json.loads(companion.read_bytes())
    except (OSError, UnicodeDecodeError, RecursionError, ValueError) as exc:
        raise InputError(companion, f"not JSON ({shown(str(exc), 80)})") from None


def thermal_csv_text(model: ThermalModel) -> str:
    """The ``thermal.csv`` text of a model (every float in its shortest exact form)."""
    sigma = model.sigma
    lines = [",".join(COLUMNS)]
    low, high = model.range_c
    for i, name in enumerate(model.names):
        c, s = model.coefficients[i], sigma[i]
        fields = [name, unit_of(name), _num(c[0]), _num(s[0]), _num(c[1]), _num(s[1]), _num(c[2]), _num(s[2]),
                  str(int(model.orders[i])), repr(float(model.reference_c)), repr(float(low)), repr(float(high))]
        lines.append(",".join(fields))
    return "\n".join(lines) + "\n"


def _num(x: float) -> str:
    return "" if not np.isfinite(x) else repr(float(x))


def thermal_json_text(model: ThermalModel, extra: dict | None = None) -> str:
    """The companion JSON: format, reference, range, names, orders and the covariance (SI), plus ``extra``."""
    data = {"format": FORMAT, "reference_c": model.reference_c, "range_c": list(model.range_c),
            "names": list(model.names), "orders": [int(o) for o in model.orders],
            "covariance_layout": "theta = [p_ref (n), a1 (n), a2 (n)], SI per degC, rows and columns in that order",
            "covariance": None if model.covariance is None else model.covariance.tolist(), **(extra or {})}
    return json.dumps(data, indent=1) + "\n"


def write_thermal(path: str | Path, model: ThermalModel, extra: dict | None = None) -> dict:
    """``{path: bytes}`` of ``NAME.csv`` and ``NAME.json`` (for :func:`core.files.write_files`)."""
    return {Path(path): thermal_csv_text(model).encode(),
            companion_path(path): thermal_json_text(model, extra).encode()}


def read_thermal(path: str | Path) -> ThermalModel:
    """Read ``thermal.csv`` (and the covariance of its companion JSON, when present).

    Raises
    ------
    InputError
        Naming the file and line of a missing column, unknown parameter or unit, or a non-number.
    """
    path = Path(path)
    check_input_file(path, "thermal model", MAX_BYTES)
    try:
        with open(path, encoding="utf-8", newline="") as handle:
            reader = csv.reader(handle)
            header = [c.strip() for c in next(reader, [])]
            rows = [(reader.line_num, row) for row in reader if row and row != [""]]
    except (UnicodeDecodeError, csv.Error) as exc:
        raise InputError(path, f"not a CSV thermal model ({shown(str(exc), 80)})") from None
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise InputError(path, f"missing columns {', '.join(missing)} (a thermal.csv of casadi-sins thermal)", line=1)
    if not rows:
        raise InputError(path, "no parameter rows")
    names, coef, sig, orders, frame = [], [], [], [], []
    for line, row in rows:
        if len(row) != len(header):
            raise InputError(path, f"{len(row)} fields, the header has {len(header)}", line=line)
        entry = dict(zip(header, (f.strip() for f in row)))
        name, factor = _name_and_factor(path, line, entry, names)
        numbers = {k: _number(path, line, entry, k) for k in COLUMNS[2:]}
        if numbers["order"] not in (1.0, 2.0):
            raise InputError(path, f"order of {name} must be 1 or 2", line=line)
        names.append(name)
        coef.append([numbers[k] * factor for k in ("p_ref", "a1", "a2")])
        sig.append([numbers[k + "_sigma"] * factor for k in ("p_ref", "a1", "a2")])
        orders.append(int(numbers["order"]))
        frame.append((numbers["reference_c"], numbers["min_c"], numbers["max_c"]))
    if len(set(frame)) != 1 or any(np.isnan(frame[0])):
        raise InputError(path, "reference_c, min_c and max_c must be given and equal on every row")
    reference, low, high = frame[0]
    covariance = _covariance(path, names, np.array(sig))
    return ThermalModel(tuple(names), reference, np.array(coef), np.array(orders), covariance, (low, high))


def _name_and_factor(path: Path, line: int, entry: dict, seen: list) -> tuple[str, float]:
    name, unit = entry["parameter"], entry["unit"]
    if not is_known(name):
        raise InputError(path, f"unknown parameter {shown(name)}", line=line)
    if name in seen:
        raise InputError(path, f"parameter {name!r} given twice", line=line)
    if unit not in TO_SI or dimension_of(unit) != dimension_of(unit_of(name)):
        raise InputError(path, f"unit {shown(unit)} does not fit {name} (expected {unit_of(name)})", line=line)
    return name, TO_SI[unit]


def _number(path: Path, line: int, entry: dict, key: str) -> float:
    text = entry[key]
    if text == "" and key.endswith("_sigma"):
        return np.nan
    try:
        value = float(text)
    except ValueError:
        raise InputError(path, f"{key} {shown(text)} of {entry['parameter']} is not a number", line=line) from None
    if not np.isfinite(value):
        raise InputError(path, f"{key} of {entry['parameter']} is not finite", line=line)
    return value


def _covariance(path: Path, names: list[str], sigma: np.ndarray) -> np.ndarray | None:
    """The companion's covariance (checked against the sigma columns), else the diagonal of the sigma."""
    companion = companion_path(path)
    n = len(names)
    doc = read_companion(path)
    if doc is None:
        diag = sigma.T.ravel()
        return None if np.all(np.isnan(diag)) else np.diag(np.nan_to_num(diag) ** 2)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise InputError(companion, f"not a thermal model covariance (format {FORMAT})")
    if doc.get("names") != names:
        raise InputError(companion, f"its parameters are not those of {path.name}, in its order")
    try:
        cov = np.array(doc["covariance"], dtype=float)
    except (KeyError, TypeError, ValueError):
        raise InputError(companion, "\"covariance\" is not a matrix of numbers") from None
    if cov.shape != (3 * n, 3 * n) or not np.all(np.isfinite(cov)):
        raise InputError(companion, f"\"covariance\" must be {3 * n} x {3 * n} finite numbers")
    diag = np.sqrt(np.clip(np.diag(cov), 0, None))
    given = np.nan_to_num(sigma.T.ravel())
    if not np.allclose(diag, given, rtol=1e-6, atol=1e-300):
        raise InputError(companion, f"its diagonal does not match the sigma columns of {path.name}")
    return cov


def is_thermal_model(path) -> bool:
    """Whether a CSV is a thermal model (its header has ``p_ref``), not a parameter table; False when it
    cannot be read (the reader of a table then names the problem)."""
    try:
        return "p_ref" in first_line(path).split(",")
    except (OSError, InputError):
        return False
