"""The parameter table: CSV ``parameter,unit,value,sigma`` (more columns may follow).

One row per parameter, values in the unit given on the row (converted to SI on reading); a truth
file has ``parameter,unit,value``.  Rows of the extra groups follow the paper's 21.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..core.errors import InputError, shown
from ..core.files import atomic_write_text
from ..core.units import TO_SI, dimension_of
from ..model.parameters import ParameterSet
from ..model.registry import groups_in, is_known, model_names, unit_of


def table_text(params: ParameterSet, truth: ParameterSet | None = None, as_truth: bool = False) -> str:
    """The parameter table CSV (header ``parameter,unit,value,sigma``, more columns after).

    ``truth`` adds truth and error columns; ``as_truth`` gives a truth file (``parameter,unit,value``).
    """
    frame = params.to_frame(truth)
    if as_truth:
        frame = frame[["parameter", "unit", "value"]]
    return frame.to_csv(index=False, na_rep="")  # shortest exact form of every float64: full precision


def write_table(path: str | Path, params: ParameterSet, truth: ParameterSet | None = None,
                as_truth: bool = False) -> Path:
    """Write the parameter table CSV (:func:`table_text`) atomically."""
    return atomic_write_text(path, table_text(params, truth, as_truth))


def read_table(path: str | Path) -> ParameterSet:
    """Read a parameter table or truth file; values in other known units are converted to SI.

    Raises
    ------
    InputError
        Naming the file and line of a missing, unknown, repeated or non-finite entry.
    """
    path = Path(path)
    try:
        frame = pd.read_csv(path, dtype={"parameter": str, "unit": str})
    except FileNotFoundError:
        raise InputError(path, "no such parameter table") from None
    except IsADirectoryError:
        raise InputError(path, "is a folder, not a parameter table") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(path, f"not a CSV parameter table ({exc})") from None
    for col in ("parameter", "unit", "value"):
        if col not in frame.columns:
            raise InputError(path, f"missing column {col!r} (header must start parameter,unit,value)", line=1)
    values: dict[str, float] = {}
    sigmas: dict[str, float] = {}
    for row, rec in enumerate(frame.itertuples(index=False)):
        line = row + 2
        name = str(rec.parameter).strip()
        if not is_known(name):
            raise InputError(path, f"unknown parameter {shown(name)}", line=line)
        if name in values:
            raise InputError(path, f"parameter {name!r} given twice", line=line)
        unit = str(rec.unit).strip()
        if unit not in TO_SI:
            raise InputError(path, f"unknown unit {shown(unit)} for {name}", line=line)
        if dimension_of(unit) != dimension_of(unit_of(name)):
            raise InputError(path, f"unit {unit!r} does not fit {name} (expected {unit_of(name)})", line=line)
        try:
            value = float(rec.value)
        except (TypeError, ValueError):
            raise InputError(path, f"value {shown(rec.value)} of {name} is not a number", line=line) from None
        if not np.isfinite(value):
            raise InputError(path, f"value of {name} is not finite", line=line)
        values[name] = value * TO_SI[unit]
        sigma = getattr(rec, "sigma", np.nan)
        try:
            sigmas[name] = float(sigma) * TO_SI[unit]
        except (TypeError, ValueError):
            sigmas[name] = np.nan
    names = model_names(groups_in(values))
    missing = [n for n in names if n not in values]
    if missing:
        raise InputError(path, f"missing parameters {', '.join(missing)}")
    sig = np.array([sigmas[n] for n in names])
    return ParameterSet(np.array([values[n] for n in names]), sigma=None if np.all(np.isnan(sig)) else sig,
                        names=names)
