"""The statistical limits of every check of a fit against its noise model (both solvers).

Under a right noise model the whitened residuals are independent with unit variance; a variance
factor with ``dof`` degrees of freedom then lies below its chi-square 99.9 % point.  The model's own
approximations get a tolerance on top.
"""

from __future__ import annotations

import numpy as np

from ..model.parameters import CORRELATION_LIMIT, ParameterSet, separation
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


def separation_warnings(params: ParameterSet, wander: dict | None = None,
                        remedy: str = SCHEDULE_REMEDY) -> tuple[list[Check], list[str]]:
    """Checks and warnings of an estimate's separability: weak parameters, inseparable pairs, condition.

    ``wander`` (sensor -> :class:`noise.wander.SensorWander`): the biases of a sensor whose bias instability
    was included are not called weak, their sigma carries the wander's mean by design (its own warning
    says so), not a schedule that cannot determine them.  ``remedy`` ends the weak parameters' warning.

    Returns ``(checks, warnings)``.
    """
    found = separation(params)
    wandering = tuple(f"{sensor}_bias_" for sensor, w in (wander or {}).items() if w.included)
    if wandering:
        found.weak = [entry for entry in found.weak if not entry[0].startswith(wandering)]
    checks = [Check("parameters determined by the schedule", float(len(found.weak)), 0.0, not found.weak,
                    "parameters whose sigma exceeds about 1 % of what is known before calibration: "
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
