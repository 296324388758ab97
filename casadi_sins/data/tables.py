"""The parameter table: CSV ``parameter,unit,value,sigma`` (more columns may follow).

One row per parameter, values in the unit given on the row (converted to SI on reading); a truth
file has ``parameter,unit,value``.  Rows of the extra groups follow the paper's 21.
"""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.errors import InputError, shown
from ..core.files import atomic_write_text
from ..core.inputs import check_input_file
from ..core.units import TO_SI, dimension_of
from ..model.output import compensate_table, compensation_matrices
from ..model.parameters import ParameterSet
from ..core.text import decimal_number
from ..model.output import sensor_matrices
from ..model.registry import (ACCEL_BIAS, ACCEL_SCALE, GYRO_BIAS, GYRO_SCALE, NAMES, groups_in, is_known, model_names,
                              unit_of)
from .recording import MAX_RATE, MAX_SPECIFIC_FORCE, PULSE_COLUMNS


@dataclasses.dataclass
class Table(ParameterSet):
    """A parameter table as :func:`read_table` gives it: a :class:`ParameterSet` that compensates raw data.

    Examples
    --------
    >>> table = read_table("unit42.csv")                      # doctest: +SKIP
    >>> increments = table.compensate(raw)                    # raw pulses in, rad and m/s out  # doctest: +SKIP
    >>> table.write("copy.csv")                               # doctest: +SKIP
    """

    def compensate(self, raw: pd.DataFrame, rate_hz: float | None = None) -> pd.DataFrame:
        """Raw pulses compensated with the table, as ``apply`` writes them.

        Parameters
        ----------
        raw : DataFrame
            Columns ``gyro_x..z`` and ``accel_x..z`` (pulses per sample), and ``time`` (s) unless
            ``rate_hz`` is given; other columns are kept unchanged.
        rate_hz : float, optional
            The sample rate (default: from the time column, as the recording description states it).

        Returns
        -------
        DataFrame
            The same rows and columns, ``gyro_*`` as angle increments (rad) and ``accel_*`` as velocity
            increments (m/s) per sample (eq. 1 inverted and every extra group's correction,
            :func:`model.output.compensate_table`), as ``apply`` writes them.
        """
        missing = [c for c in PULSE_COLUMNS if c not in raw.columns]
        if missing:
            raise ValueError(f"the raw data lack the columns {', '.join(missing)}")
        dt = 1.0 / (rate_hz if rate_hz is not None else _rate_of(raw))
        dtheta, dv = compensate_table(raw[list(PULSE_COLUMNS[:3])].to_numpy(float),
                                      raw[list(PULSE_COLUMNS[3:])].to_numpy(float), self.values, self.names, dt)
        out = raw.copy()
        out[list(PULSE_COLUMNS)] = np.hstack([dtheta, dv])
        return out

    def matrices(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Per sensor (``"gyro"``, ``"accel"``) ``(M, c)`` with ``increment = M dN + c dt`` (SI; the exports')."""
        return compensation_matrices(self.values)

    def write(self, path: str | Path) -> Path:
        """Write the table CSV (:func:`write_table`); :func:`read_table` reads it back exactly."""
        return write_table(path, self)


def _rate_of(raw: pd.DataFrame) -> float:
    """The sample rate of a time column, to 9 significant digits (as a description's ``rate_hz``)."""
    if "time" not in raw.columns or len(raw) < 2:
        raise ValueError("give rate_hz, or a time column of at least two samples")
    step = float(np.median(np.diff(raw["time"].to_numpy(float))))
    if not step > 0:
        raise ValueError("the time column does not increase")
    return float(f"{1.0 / step:.9g}")


def table_text(params: ParameterSet, truth: ParameterSet | None = None, as_truth: bool = False,
               acceptance: dict[str, str] | None = None, distrusted: bool = False) -> str:
    """The parameter table CSV (header ``parameter,unit,value,sigma``, more columns after).

    ``truth`` adds truth and error columns; ``as_truth`` gives a truth file (``parameter,unit,value``);
    ``acceptance`` (``{name: "pass" | "fail"}``, from a tolerance sheet) adds the column ``acceptance``
    (empty for a parameter without a limit), marking the parameters that fail; ``distrusted`` adds the
    column ``trust``, ``distrusted`` in every row (a table the calibration's checks do not trust, written
    on request).
    """
    frame = params.to_frame(truth)
    if as_truth:
        frame = frame[["parameter", "unit", "value"]]
    elif acceptance is not None:
        frame["acceptance"] = [acceptance.get(n, "") for n in params.names]
    if distrusted and not as_truth:
        frame["trust"] = "distrusted"
    return frame.to_csv(index=False, na_rep="")  # shortest exact form of every float64: full precision


def write_table(path: str | Path, params: ParameterSet, truth: ParameterSet | None = None,
                as_truth: bool = False) -> Path:
    """Write the parameter table CSV (:func:`table_text`) atomically."""
    return atomic_write_text(path, table_text(params, truth, as_truth))


#: A parameter table is a few dozen rows.
MAX_TABLE_BYTES = 1_000_000


def read_table(path: str | Path) -> Table:
    """Read a parameter table or truth file (a :class:`Table`); values in other known units are converted to SI.

    Every row must have exactly the header's number of fields.

    Raises
    ------
    InputError
        Naming the file and line of a missing, unknown, repeated or non-finite entry.
    """
    path = Path(path)
    check_input_file(path, "parameter table", MAX_TABLE_BYTES)
    header, rows = _rows(path)
    values: dict[str, float] = {}
    sigmas: dict[str, float] = {}
    for line, row in rows:
        name, value, sigma = _entry(path, line, dict(zip(header, row)), values)
        values[name], sigmas[name] = value, sigma
    names = model_names(groups_in(values))
    missing = [n for n in names if n not in values]
    if missing:
        raise InputError(path, f"missing parameters {', '.join(missing)}")
    sig = np.array([sigmas[n] for n in names])
    params = Table(np.array([values[n] for n in names]), sigma=None if np.all(np.isnan(sig)) else sig, names=names)
    check_table(path, params)
    return params


#: The largest condition number of a misalignment matrix K (unit diagonal; a real unit's is within 1.01).
MAX_CONDITION = 100.0
#: Pulse weights (SI per pulse) outside this range are no sensor's (1 is a compensated recording's).
SCALE_RANGE = (1e-15, 1e3)


def check_table(path, params: ParameterSet) -> None:
    """A table that compensation can use: pulse weights within :data:`SCALE_RANGE` in size, biases within
    what any unit measures, misalignment matrices invertible with a condition number within
    :data:`MAX_CONDITION` (eq. 1 is inverted with ``K^-1``).

    Raises
    ------
    InputError
        Naming the file and the parameter (or matrix) at fault.
    """
    p = np.asarray(params.core, dtype=float)
    for span, sensor in ((ACCEL_SCALE, "accelerometer"), (GYRO_SCALE, "gyro")):
        for name, value in zip(NAMES[span], p[span]):
            if not SCALE_RANGE[0] <= abs(value) <= SCALE_RANGE[1]:
                raise InputError(path, f"{name} = {value:.6g} {unit_of(name)}: no {sensor} has this pulse weight "
                                 f"(its size must be within {SCALE_RANGE[0]:g}..{SCALE_RANGE[1]:g})")
    for span, limit, unit in ((ACCEL_BIAS, MAX_SPECIFIC_FORCE, "m/s^2"), (GYRO_BIAS, MAX_RATE, "rad/s")):
        for name, value in zip(NAMES[span], p[span]):
            if abs(value) > limit:
                raise InputError(path, f"{name} = {value:.6g} {unit}: beyond anything a unit measures "
                                 f"({limit:.3g} {unit})")
    k_a, _, _, k_g, _, _ = (np.asarray(m, dtype=float) for m in sensor_matrices(p))
    for k, sensor in ((k_a, "accelerometer"), (k_g, "gyro")):
        condition = np.linalg.cond(k) if np.all(np.abs(k) < 1e3) else np.inf
        if not condition <= MAX_CONDITION:
            what = "singular" if not condition < 1e12 else "ill-conditioned"
            raise InputError(path, f"the {sensor} misalignments make K {what} (condition number {condition:.3g}, "
                             f"at most {MAX_CONDITION:g}): the table cannot compensate (eq. 1 inverted)")


def _rows(path: Path) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """Header and ``(line, fields)`` of every non-empty row; each row exactly as wide as the header."""
    try:
        with open(path, encoding="utf-8", newline="") as handle:
            reader = csv.reader(handle)
            header = [c.strip() for c in next(reader, [])]
            rows = [(reader.line_num, row) for row in reader if row and row != [""]]
    except UnicodeDecodeError as exc:
        raise InputError(path, f"not UTF-8 text ({exc.reason})") from None
    except csv.Error as exc:
        raise InputError(path, f"not a CSV parameter table ({exc})") from None
    for col in ("parameter", "unit", "value"):
        if col not in header:
            raise InputError(path, f"missing column {col!r} (header must start parameter,unit,value)", line=1)
    for line, row in rows:
        if len(row) != len(header):
            raise InputError(path, f"{len(row)} fields, the header has {len(header)}", line=line)
    return header, rows


def _entry(path: Path, line: int, row: dict, seen: dict) -> tuple[str, float, float]:
    """``(name, SI value, SI sigma or nan)`` of one row."""
    name = row["parameter"].strip()
    if not is_known(name):
        raise InputError(path, f"unknown parameter {shown(name)}", line=line)
    if name in seen:
        raise InputError(path, f"parameter {name!r} given twice", line=line)
    unit = row["unit"].strip()
    if unit not in TO_SI:
        raise InputError(path, f"unknown unit {shown(unit)} for {name}", line=line)
    if dimension_of(unit) != dimension_of(unit_of(name)):
        raise InputError(path, f"unit {unit!r} does not fit {name} (expected {unit_of(name)})", line=line)
    try:
        value = decimal_number(row["value"])
    except ValueError:
        if row["value"].strip().lower().lstrip("+-") in ("inf", "infinity", "nan"):
            raise InputError(path, f"value of {name} is not finite", line=line) from None
        raise InputError(path, f"value {shown(row['value'])} of {name} is not a number", line=line) from None
    if not np.isfinite(value):
        raise InputError(path, f"value of {name} is not finite", line=line)
    text = row.get("sigma", "").strip()
    try:
        sigma = decimal_number(text) * TO_SI[unit] if text else np.nan
    except ValueError:
        raise InputError(path, f"sigma {shown(text)} of {name} is not a number", line=line) from None
    if not (np.isnan(sigma) or (np.isfinite(sigma) and sigma >= 0)):
        raise InputError(path, f"sigma of {name} must be a non-negative finite number", line=line)
    return name, value * TO_SI[unit], sigma
