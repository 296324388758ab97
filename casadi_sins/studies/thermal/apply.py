"""A recording compensated with a thermal model: at one temperature, or sample by sample at its own.

With the recording's ``temperature`` column each sample is compensated with the parameters at its
temperature (rounded to :data:`RESOLUTION_C`: with coefficients of a few ug or ppm per degC the
rounding moves a parameter by a few thousandths of its unit, far below any sigma), as the unit's
firmware does with ``casadi_sins_compensate_t``.  As there, a temperature outside the calibrated range is
held at the nearest end of it (:meth:`model.thermal.ThermalModel.clamped`), with a note.  The check at rest
is that of :mod:`studies.apply`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...core.errors import InputError
from ...data.recording import Recording
from ...model.output import compensate
from ...model.registry import N_PARAMS
from ...model.thermal import ThermalModel
from ..apply import Applied, apply_table, judged_check, static_check, table_sigma

#: Samples whose temperatures agree to this are compensated with one table, degC.
RESOLUTION_C = 0.01


def apply_thermal(rec: Recording, model: ThermalModel, temperature_c: float | None = None) -> Applied:
    """Compensate ``rec`` with ``model`` at ``temperature_c``, or per sample at its ``temperature`` column.

    Raises
    ------
    ValueError
        Without a temperature and without a temperature column.
    """
    if temperature_c is not None:
        applied = apply_table(rec, model.at(model.clamped(temperature_c)))
        applied.notes.extend(_range_notes(model, np.array([temperature_c])))
        return applied
    if rec.temperature is None:
        raise ValueError("no temperature given and no temperature column")
    temps = np.round(np.asarray(rec.temperature, float) / RESOLUTION_C) * RESOLUTION_C
    dtheta, dv = np.empty_like(rec.gyro, dtype=float), np.empty_like(rec.accel, dtype=float)
    for t in np.unique(temps):
        rows = temps == t
        t = model.clamped(t)
        dtheta[rows], dv[rows] = compensate(rec.gyro[rows], rec.accel[rows], model.values_at(t)[:N_PARAMS], rec.dt)
    compensated = dataclasses.replace(rec, name=f"{rec.name}-compensated", gyro=dtheta, accel=dv, source=None,
                                      temperature=None, warnings=list(rec.warnings))
    notes = [f"compensated sample by sample at the recording's temperature column ({temps.min():.4g} .. "
             f"{temps.max():.4g} degC)"] + _range_notes(model, temps)
    if len(model.names) > N_PARAMS:
        notes.append("the model's extra terms are not applied: only the 21 parameters of eq. 1 compensate sample by "
                     "sample")
    middle = model.at(model.clamped(float(np.mean(temps))))  # the table's sigma at the recording's mean temperature
    return Applied(compensated, judged_check(static_check(compensated), table_sigma(rec, middle)), notes)


def apply_thermal_at_recording(rec: Recording, model: ThermalModel, model_label: str,
                               temperature_c: float | None = None, given_as: str = "the given temperature") -> Applied:
    """``apply --thermal``: ``rec`` compensated with ``model`` at ``temperature_c`` when given, else at the
    recording's ``[conditions] temperature_c``, else sample by sample at its temperature column; a note says
    which (``given_as``: how the caller names a given temperature, such as its option).

    Raises
    ------
    InputError
        When there is no temperature at all (none given, no conditions, no temperature column).
    """
    temperature, source = temperature_c, given_as
    if temperature is None and rec.conditions.temperature_c is not None:
        temperature, source = rec.conditions.temperature_c, "the recording's [conditions]"
    if temperature is None and rec.temperature is None:
        raise InputError(rec.label, f"no temperature ([conditions] temperature_c or a temperature column): give "
                         f"{given_as}")
    applied = apply_thermal(rec, model, temperature)
    if temperature is not None:
        applied.notes.insert(0, f"thermal model {model_label} evaluated at {temperature:.4g} degC (from {source})")
    return applied


def _range_notes(model: ThermalModel, temps: np.ndarray) -> list[str]:
    low, high = model.range_c
    if temps.min() < low or temps.max() > high:
        return [f"temperatures beyond the calibrated range {low:g} .. {high:g} degC ({temps.min():.4g} .. "
                f"{temps.max():.4g} degC): the model is evaluated at the nearest end of the range, as the firmware "
                "header does (casadi_sins_compensate_t returns 1 there)"]
    return []
