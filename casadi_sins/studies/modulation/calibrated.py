"""A calibrated parameter table as the error sources of the modulation analysis.

The residual errors of a calibrated unit are the uncertainty of its table (``read_table``): the sigma
column, or the full covariance when one is known:

* ``--covariance C.csv``: a square CSV, header ``parameter,<names>``, one row per name, in the SI units
  of the table (the 21 names, or every name of the table);
* otherwise the companion report ``NAME.report.json`` beside the table ``NAME.csv``, when it has a
  ``"covariance"`` key: a list of lists in SI, rows and columns in the table's parameter order.

Either must be symmetric, positive semi-definite and have the table's sigma as its diagonal root.
Scale-factor errors are relative (``t_ii``), so the covariance of the values is divided by the values
(:func:`casadi_sins.model.registry.relative_covariance`, as the budget does).  Every group of the table
is a source (the error model is the package's one, :mod:`casadi_sins.nav.errorinputs`): the gyro
g-sensitivity and scale asymmetry, the accelerometer quadratic scale, lever arms and time offset as the
21.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from ...core.errors import InputError
from ...core.inputs import check_input_file
from ...data.record import check_psd, read_record
from ...model.registry import NAMES, error_scale, groups_in, model_names, relative_covariance
from .model import N_NAV
from .sources import Sources

#: A covariance CSV of a few dozen parameters is small.
MAX_COVARIANCE_BYTES = 20_000_000


def read_covariance_csv(path, names: tuple[str, ...]) -> np.ndarray:
    """A square covariance CSV (header ``parameter,<names>``) in the order of ``names``.

    Its rows and columns must be the same names: ``names`` itself, or the 21 of them.

    Raises
    ------
    InputError
        Naming the file and line at fault.
    """
    path = Path(path)
    check_input_file(path, "covariance CSV", MAX_COVARIANCE_BYTES)
    try:
        with open(path, encoding="utf-8", newline="") as handle:
            rows = [(k, row) for k, row in enumerate(csv.reader(handle), start=1) if row and row != [""]]
    except UnicodeDecodeError as exc:
        raise InputError(path, f"not UTF-8 text ({exc.reason})") from None
    except csv.Error as exc:
        raise InputError(path, f"not a CSV covariance ({exc})") from None
    if not rows:
        raise InputError(path, "empty: expected a header parameter,<names> and one row per name")
    header = [c.strip() for c in rows[0][1][1:]]
    labels = [row[0].strip() for _, row in rows[1:]]
    usable = {tuple(names), NAMES}
    if len(set(header)) != len(header) or set(header) != set(labels) or not any(set(header) == set(u) for u in usable):
        raise InputError(path, "rows and columns must be the same parameter names, those of the table or the 21",
                         line=1)
    matrix = np.zeros((len(header), len(header)))
    for i, (line, row) in enumerate(rows[1:]):
        if len(row) != len(header) + 1:
            raise InputError(path, f"{len(row)} fields, the header has {len(header) + 1}", line=line)
        try:
            matrix[i] = [float(x) for x in row[1:]]
        except ValueError:
            raise InputError(path, f"row {labels[i]!r} has an entry that is not a number", line=line) from None
    if not np.all(np.isfinite(matrix)):
        raise InputError(path, "the covariance has non-finite entries")
    order = [labels.index(n) for n in header]  # rows in the header's order
    return _reorder(matrix[order], header, names)


def _reorder(matrix: np.ndarray, given: list[str], names: tuple[str, ...]) -> np.ndarray:
    """A covariance over ``given`` names as one over ``names`` (zero where ``given`` lacks a name)."""
    out = np.zeros((len(names), len(names)))
    pos = [names.index(n) for n in given]
    out[np.ix_(pos, pos)] = matrix
    return out


def table_sources(table, covariance=None, sheet: Sources | None = None) -> Sources:
    """Residual errors of a calibrated table: its sigma, or its full covariance (error-state form:
    scale factors relative), with the initial errors and noise of ``sheet`` (none without a sheet).

    Parameters
    ----------
    table : str or Path
        The parameter table CSV (with sigma).
    covariance : str or Path, optional
        A covariance CSV; without it, the covariance of ``NAME.report.json`` beside the table, if any.
    sheet : Sources, optional

    Raises
    ------
    InputError
        Naming the table, the covariance file or the report at fault.
    """
    table = Path(table)
    record = read_record(table)
    params = record.table_parameters
    names = params.names
    if params.sigma is None or np.any(np.isnan(params.sigma[: len(NAMES)])):
        missing = NAMES if params.sigma is None else [n for n, s in zip(names, params.sigma) if math.isnan(s)]
        raise InputError(table, f"no sigma for {', '.join(missing[:3])}{', ...' if len(missing) > 3 else ''}: the "
                         "residual errors are the table's uncertainty (a calibrated table has a sigma column)")
    cov, where = np.diag(np.nan_to_num(params.sigma) ** 2), None
    if covariance is not None:
        cov, where = read_covariance_csv(covariance, names), Path(covariance)
        check_psd(cov, where)
        if not np.allclose(np.sqrt(np.diag(cov))[: len(NAMES)], params.sigma[: len(NAMES)], rtol=1e-3, atol=0.0):
            raise InputError(where, f"its diagonal does not match the sigma of {table}")
    elif record.covariance is not None:  # checked against the table by the record
        cov, where = record.covariance, record.report_path
    zero = np.zeros(3)
    try:
        return parameter_sources(names, params.values, cov, zero if sheet is None else sheet.gyro_arw,
                                 zero if sheet is None else sheet.accel_vrw, sheet, name=table.stem,
                                 correlated=where is not None,
                                 origin=str(table) + (f" + {where}" if where is not None else ""))
    except ValueError as exc:
        raise InputError(table, str(exc)) from None


def parameter_sources(names, values: np.ndarray, covariance: np.ndarray, gyro_arw: np.ndarray,
                      accel_vrw: np.ndarray, sheet: Sources | None = None, name: str = "calibration",
                      correlated: bool = True, origin: str = "") -> Sources:
    """Residual errors of parameters ``names`` with ``values`` and ``covariance`` (SI) as the modulation's
    error sources: every group of the registry they hold is a state (the 21, then the extra groups, with the
    sheet's where the table has none), scale factors made relative (:func:`model.registry.relative_covariance`),
    the white noise ``gyro_arw`` (rad/sqrt(s)) and ``accel_vrw`` (m/s/sqrt(s)), the initial errors of ``sheet``
    (none without one).

    Raises
    ------
    ValueError
        If a scale factor is zero (its relative error is undefined).
    """
    names, values = tuple(names), np.asarray(values, float)
    if np.any(error_scale(names, values) == 0):
        raise ValueError("a scale factor of zero")
    sheet_names = () if sheet is None else sheet.names
    state_names = model_names(groups_in(names + tuple(sheet_names)))
    n = N_NAV + len(state_names)
    p0 = np.zeros((n, n))
    if sheet is not None:
        where = list(range(N_NAV)) + [N_NAV + state_names.index(s) for s in sheet_names]
        p0[np.ix_(where, where)] = sheet.p0
    idx = [N_NAV + state_names.index(s) for s in names]
    p0[np.ix_(idx, idx)] = relative_covariance(names, values, covariance)
    return Sources(name, p0, np.asarray(gyro_arw, float), np.asarray(accel_vrw, float), correlated=correlated,
                   origin=origin, names=state_names)
