"""The statistical limits of every check of a fit against its noise model (both solvers).

Under a right noise model the whitened residuals are independent with unit variance; a variance
factor with ``dof`` degrees of freedom then lies below its chi-square 99.9 % point.  The model's own
approximations get a tolerance on top.
"""

from __future__ import annotations

import numpy as np

from ..model.parameters import CORRELATION_LIMIT, ParameterSet, separation
from ..model.registry import group_of
from .result import Check

#: Relative tolerance of the noise model on top of the sampling error of a variance factor.
MODEL_TOLERANCE = 0.15
#: Standard normal quantile of the checks (99.9 %, one-sided).
Z_LIMIT = 3.1


def factor_limit(dof: float) -> float:
    """Upper limit of a variance factor with ``dof`` degrees of freedom (chi-square, 99.9 %, plus the model
    tolerance)."""
    return 1.0 + Z_LIMIT * np.sqrt(2.0 / max(dof, 1.0)) + MODEL_TOLERANCE


def factor_low(dof: float) -> float:
    """Lower limit of a variance factor with ``dof`` degrees of freedom (chi-square, 0.1 %, less the model
    tolerance): a fit this much better than its noise model means the model is too large."""
    return max(0.0, 1.0 - Z_LIMIT * np.sqrt(2.0 / max(dof, 1.0)) - MODEL_TOLERANCE)


#: The remedy a weak parameter's warning names, when no term outside the model explains the misfit.
SCHEDULE_REMEDY = "turn the unit about more axes or longer"
#: A parameter is not determined by the schedule when its sigma exceeds this many times what the unit's own noise
#: could give it in the session's rests and moves (:func:`grade_levels`), and its group's navigation-grade level.
GRADE_FACTOR = 100.0
#: Turns of an ideal schedule (90 deg in this many seconds each) for the gyro scale factors' and misalignments' floor.
GRADE_TURNS = 12
GRADE_TURN_S = 2.0


def grade_floors(names, noise, rest_s: float, gravity: float) -> dict[str, float]:
    """What a unit's own white noise could give each parameter in a session with ``rest_s`` seconds of rest
    (natural units; names without such a floor are left out): the accelerometers' from the
    rests' mean specific force (VRW over the rests; a misalignment shows at most half of it, at 45 deg between
    the axes), the gyro biases and g-sensitivity from the rests' mean rate
    (ARW), the gyro scale factors, misalignments and asymmetry from :data:`GRADE_TURNS` turns of 90 deg, each
    seen by the tilt of the rests beside it and blurred by the angle random walk over :data:`GRADE_TURN_S`."""
    vrw = float(np.mean(noise.accel_vrw)) if noise.accel_vrw is not None else 0.0
    arw = float(np.mean(noise.gyro_arw)) if noise.gyro_arw is not None else 0.0
    rest_s, turns = max(rest_s, 1e-9), GRADE_TURNS
    force = vrw / np.sqrt(rest_s)
    attitude = np.sqrt(2.0 * force**2 * turns / gravity**2 + arw**2 * GRADE_TURN_S)
    si = {"accel_bias": force, "accel_scale": force / gravity, "accel_misalign": 2.0 * force / gravity,  # sin cos
          "gyro_bias": arw / np.sqrt(rest_s), "gyro_gsens": arw / np.sqrt(rest_s) / gravity,
          "gyro_scale": attitude / (np.pi / 2) / np.sqrt(turns)}
    si["gyro_misalign"] = si["gyro_asym"] = si["gyro_scale"]
    out = {}
    for name in names:
        key = group_of(name).key
        if key in si:
            out[name] = float(si[key] / (1e-6 if group_of(name).relative else group_of(name).natural_scale))
    return out


def grade_levels(names, noise, rec) -> dict[str, float]:
    """The thresholds of "not determined" by the unit's grade (natural units): :data:`GRADE_FACTOR` times its
    floor (:func:`grade_floors`, the recording's rest time), never below the group's navigation-grade
    ``weak_level`` (a navigation-grade unit is judged as before)."""
    rest = sum(s.end - s.start for s in rec.segments if s.is_static)
    floors = grade_floors(names, noise, rest, rec.site.g)
    return {n: max(group_of(n).weak_level, GRADE_FACTOR * f) for n, f in floors.items()}


def separation_warnings(params: ParameterSet, wander: dict | None = None,
                        remedy: str = SCHEDULE_REMEDY, levels: dict[str, float] | None = None
                        ) -> tuple[list[Check], list[str]]:
    """Checks and warnings of an estimate's separability: weak parameters, inseparable pairs, condition.

    ``wander`` (sensor -> :class:`noise.wander.SensorWander`): the biases of a sensor whose bias instability
    was included are not called weak, their sigma carries the wander's mean by design (its own warning
    says so), not a schedule that cannot determine them.  ``remedy`` ends the weak parameters' warning.
    ``levels``: the thresholds of a weak parameter by the unit's grade (:func:`grade_levels`; default the
    groups' navigation-grade ``weak_level``).

    Returns ``(checks, warnings)``.
    """
    found = separation(params, levels)
    wandering = tuple(f"{sensor}_bias_" for sensor, w in (wander or {}).items() if w.included)
    if wandering:
        found.weak = [entry for entry in found.weak if not entry[0].startswith(wandering)]
    checks = [Check("parameters determined by the schedule", float(len(found.weak)), 0.0, not found.weak,
                    (f"parameters whose sigma exceeds {GRADE_FACTOR:g} times what the unit's noise could give them, and about 1 % of "
                     "what is known before calibration (biases at their scale factors): " if levels else
                     "parameters whose sigma exceeds about 1 % of what is known before calibration: ")
                    + (", ".join(f"{n} {s:.3g} {u}" for n, s, u in found.weak) or "none")),
              Check("parameters separated by the schedule", float(len(found.correlated)), 0.0, not found.correlated,
                    f"pairs correlated beyond {CORRELATION_LIMIT}; condition number of the correlations "
                    f"{found.condition:.3g}")]
    warnings = []
    if found.weak:
        lead = "the schedule" if remedy == SCHEDULE_REMEDY else "this fit"
        warnings.append(f"{lead} does not determine " + ", ".join(f"{n} (sigma {s:.3g} {u})"
                                                                       for n, s, u in found.weak[:8])
                        + (", ..." if len(found.weak) > 8 else "") + f": {remedy}")
    if found.correlated:
        warnings.append("the schedule cannot separate " + ", ".join(f"{a} from {b} (correlation {c:+.4f})"
                                                                   for a, b, c in found.correlated[:5])
                        + (", ..." if len(found.correlated) > 5 else "")
                        + f" (condition number {found.condition:.3g}): their sum is known, not each one")
    return checks, warnings
