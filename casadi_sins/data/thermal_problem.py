"""A thermal problem: a problem file (:mod:`data.problem`) with the unit's temperature model and setpoints.

Beside the usual sections, ``[thermal]``::

    [thermal]
    reference_c = 25                          # T_ref, degC; [truth] is the unit at T_ref
    setpoints_c = [-30, -10, 10, 25, 40, 60]  # one recording per chamber setpoint
    unit_id = "SN-0042"                       # optional, into each recording's [conditions]
    [thermal.linear]                          # a1 per parameter, natural unit of its error per degC
    accel_bias_x = -0.8                       #   ug/degC
    gyro_scale_y = 0.4                        #   ppm/degC (of the value at T_ref)
    [thermal.quadratic]                       # a2, natural unit per degC^2 (optional)
    accel_bias_x = 0.004

Every parameter not named keeps its ``[truth]`` value at every temperature.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ..core.errors import InputError, shown
from ..core.toml import read_toml
from ..model.registry import natural_size
from ..model.thermal import ThermalModel
from .conditions import TEMPERATURE_RANGE_C
from .problem import Problem, load_problem


@dataclasses.dataclass(frozen=True)
class ThermalProblem:
    """The experiment at each setpoint: the problem (truth at ``T_ref``), the true thermal model, the setpoints."""

    problem: Problem
    model: ThermalModel
    setpoints_c: tuple[float, ...]
    unit_id: str | None = None


def has_thermal(path: str | Path | None) -> bool:
    """Whether a problem file has a ``[thermal]`` section."""
    return path is not None and isinstance(read_toml(path, "problem file").get("thermal"), dict)


def load_thermal_problem(path: str | Path) -> ThermalProblem:
    """Read a thermal problem.

    Raises
    ------
    InputError
        Naming the file and the key at fault.
    """
    path = Path(path)
    problem = load_problem(path)
    section = read_toml(path, "problem file").get("thermal")
    if not isinstance(section, dict):
        raise InputError(path, "no [thermal] section (reference_c, setpoints_c, [thermal.linear])")
    unknown = set(section) - {"reference_c", "setpoints_c", "unit_id", "linear", "quadratic"}
    if unknown:
        raise InputError(path, f"[thermal] unknown key(s) {', '.join(sorted(unknown))}")
    reference = _temperature(path, section.get("reference_c", 25.0), "reference_c")
    points = section.get("setpoints_c")
    if not isinstance(points, list) or not points:
        raise InputError(path, "[thermal] setpoints_c must be a list of temperatures (degC)")
    setpoints = tuple(_temperature(path, t, "setpoints_c") for t in points)
    truth = problem.truth
    size = natural_size(truth.names, truth.values)
    coef = np.column_stack([truth.values, np.zeros(len(size)), np.zeros(len(size))])
    for column, key in ((1, "linear"), (2, "quadratic")):
        for name, value in _coefficients(path, section.get(key, {}), key, truth.names).items():
            i = truth.names.index(name)
            coef[i, column] = value * size[i]
    unit = section.get("unit_id")
    model = ThermalModel(truth.names, reference, coef, np.where(coef[:, 2] != 0.0, 2, 1), None,
                         (min(setpoints), max(setpoints)))
    return ThermalProblem(problem, model, setpoints, None if unit is None else str(unit))


def _temperature(path: Path, value, key: str) -> float:
    low, high = TEMPERATURE_RANGE_C
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value <= high:
        raise InputError(path, f"[thermal] {key}: {shown(value)} is not a temperature within {low:g}..{high:g} degC")
    return float(value)


def _coefficients(path: Path, table, key: str, names) -> dict[str, float]:
    if not isinstance(table, dict):
        raise InputError(path, f"[thermal.{key}] must be a table of parameter = value")
    out = {}
    for name, value in table.items():
        if name not in names:
            raise InputError(path, f"[thermal.{key}] {shown(name)} is not a parameter of the problem's [truth]")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(path, f"[thermal.{key}] {name}: {shown(value)} is not a number")
        out[name] = float(value)
    return out
