"""Consistency checks of a calibration against its noise model, and the honest variance factor.

Under a right noise model the Kalman-whitened residuals (:mod:`kalman`) are independent with unit
variance, whatever the sensor.  Each check below compares a statistic of them with its distribution
under that hypothesis; the limits are the 99.9 % points plus a tolerance for the model's own
approximations.  A failed check writes a warning and, where it means the residuals are larger than
the model says, multiplies the covariance by the observed variance factor: the sigma is then that of
the data, not of the model.

Checks
    * velocity and gyro-mean residuals against the noise measured in the raw data (variance factor
      per kind; raw against fitted noise);
    * drift within static segments (low-frequency excess: bias instability, thermal drift);
    * whiteness (lag-one correlation of consecutive innovations);
    * each group's chi-square;
    * the Gauss-Newton steps after Ipopt (converged, and how far they moved).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .noise import SensorNoise

#: Relative tolerance of the noise model on top of the sampling error of a variance factor.
MODEL_TOLERANCE = 0.15
#: Standard normal quantile of the checks (99.9 %, one-sided).
Z_LIMIT = 3.1


@dataclasses.dataclass
class Check:
    name: str
    value: float
    limit: float
    passed: bool
    detail: str

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclasses.dataclass
class Assessment:
    checks: list[Check]
    warnings: list[str]
    factors: dict[str, float]
    variance_factor: float
    fitted_noise: SensorNoise
    model_fails: bool = False  # residuals beyond the model: velocity, gyro or drift check failed


def factor_limit(dof: float) -> float:
    """Upper limit of a variance factor with ``dof`` degrees of freedom (chi-square, 99.9 %, plus the model
    tolerance)."""
    return 1.0 + Z_LIMIT * np.sqrt(2.0 / max(dof, 1.0)) + MODEL_TOLERANCE


def assess(rec, problem, fit: dict, noise_plan) -> Assessment:
    """Run every check on a finished fit (see the module docstring)."""
    rw = fit["whitened_residuals"]
    leverage = fit["leverage"]
    checks: list[Check] = []
    warnings: list[str] = []
    inflate = 1.0
    factors = {}
    model_fails = False
    for label, kind in (("velocity", 0), ("gyro", 1)):
        rows = problem.kind == kind
        dof = float(rows.sum() - leverage[rows].sum())
        factor = float(np.sum(rw[rows] ** 2) / dof) if dof > 0.5 else 1.0
        factors[label] = factor
        free = noise_plan.free_terms()[label]
        limit = factor_limit(dof)
        passed = factor <= limit
        model_fails |= not passed
        detail = (f"{label} residuals {np.sqrt(factor):.3g} times the noise model ({dof:.0f} degrees of freedom; "
                  + (f"{', '.join(free)} set by the fit within the raw data's bound)" if free else "raw data)"))
        checks.append(Check(f"{label} residuals vs noise model", factor, limit, passed, detail))
        if not passed:
            inflate = max(inflate, factor)
            warnings.append(f"the {label} residuals are {np.sqrt(factor):.3g} times larger than the sensor noise "
                            "measured in the raw data: errors outside the model (model mismatch, base motion, "
                            f"drift); sigma inflated by {np.sqrt(factor):.3g}")
    low, dof = drift_statistic(problem, rw, fit["left_singular_vectors"])
    velocity = np.flatnonzero(problem.kind == 0)
    if dof > 0:
        limit = factor_limit(dof)
        passed = low <= limit
        model_fails |= not passed
        checks.append(Check("drift within static segments", low, limit, passed,
                            f"mean square of the segment sums of whitened velocity residuals ({dof:.0f} degrees "
                            "of freedom after the fit; 1 without drift)"))
        if not passed:
            inflate = max(inflate, low)
            warnings.append(f"the velocity drifts within static segments {np.sqrt(low):.3g} times more than the "
                            "noise model allows: bias instability or thermal drift not in the model (give the "
                            f"datasheet's bias instability); sigma inflated by {np.sqrt(low):.3g}")
    # whiteness: lag-one correlation of consecutive velocity innovations of one axis
    pairs = []
    for seg in np.unique(problem.row_segment[velocity]):
        rows = velocity[problem.row_segment[velocity] == seg]
        for axis in range(3):
            sel = rows[axis::3]
            pairs.append(np.column_stack([rw[sel][:-1], rw[sel][1:]]))
    pairs = np.vstack(pairs) if pairs else np.zeros((0, 2))
    if len(pairs) > 10:
        rho = float(np.sum(pairs[:, 0] * pairs[:, 1]) / np.sqrt(np.sum(pairs[:, 0] ** 2) * np.sum(pairs[:, 1] ** 2)))
        limit = Z_LIMIT / np.sqrt(len(pairs)) + 0.1
        passed = abs(rho) <= limit
        checks.append(Check("whiteness (lag-one correlation)", rho, limit, passed,
                            f"correlation of consecutive whitened velocity residuals, {len(pairs)} pairs"))
        if not passed:
            warnings.append(f"consecutive velocity residuals are correlated ({rho:+.2f}): the noise is not the "
                            "modelled one (vibration, unmodelled motion)")
    # chi-square of each group
    for group in np.unique(problem.row_group):
        rows = problem.row_group == group
        dof = float(rows.sum() - leverage[rows].sum())
        factor = float(np.sum(rw[rows] ** 2) / max(dof, 1.0))
        limit = factor_limit(dof)
        passed = factor <= limit
        checks.append(Check(f"group {group} chi-square", factor, limit, passed,
                            f"whitened residuals of group {group}, {dof:.0f} degrees of freedom"))
        if not passed and factor > max(factors.values()) * 1.2:
            warnings.append(f"group {group} fits {np.sqrt(factor):.3g} times worse than the noise: a disturbance "
                            "in that group (handling, shock)?")
    # velocity steps across rotations against the static residuals (lever arms, timing offset?)
    if fit.get("use_rotation_steps"):
        from .nlp import STEP_CONSISTENCY_LIMIT

        ratio = fit["rotation_step_ratio"]
        passed = ratio <= STEP_CONSISTENCY_LIMIT
        model_fails |= not passed
        checks.append(Check("velocity steps across rotations", ratio, STEP_CONSISTENCY_LIMIT, passed,
                            "mean square of the whitened residuals after rotations over that of the others"))
        if not passed:
            warnings.append(f"the velocity steps across rotations fit {np.sqrt(ratio):.3g} times worse than the "
                            "static residuals: terms outside the model act during the rotations")
    # the Gauss-Newton steps after Ipopt
    from .nlp import GLS_LINEAR_STEP

    steps = fit["gls_steps"]
    converged = steps[-1] < GLS_LINEAR_STEP
    checks.append(Check("post-solve steps converged", steps[-1], GLS_LINEAR_STEP, converged,
                        f"generalised least-squares steps after Ipopt: {', '.join(f'{s:.3g}' for s in steps)} sigma "
                        "(the last one, in the linear region, is applied without another evaluation)"))
    if not converged:
        warnings.append(f"the generalised least squares did not settle (last step {steps[-1]:.3g} sigma)")
    fitted = _fitted_noise(fit["noise"], noise_plan, factors)
    return Assessment(checks, warnings, factors, inflate, fitted, model_fails)


def drift_statistic(problem, rw: np.ndarray, basis: np.ndarray) -> tuple[float, float]:
    """Drift within static segments: mean square of the segment sums of whitened velocity residuals.

    A slow error (bias instability, drift, an unmodelled slope) makes the sums of consecutive
    innovations large.  The fitted parameters take out part of every sum (its leverage), so
    ``E[sum^2 / n] = 1 - ||U^T a||^2`` with ``U`` the left singular vectors of the whitened Jacobian.
    Returns ``(statistic, expected sum)``; the statistic is 1 without drift.
    """
    velocity = np.flatnonzero(problem.kind == 0)
    sums, expected = [], []
    for seg in np.unique(problem.row_segment[velocity]):
        rows = velocity[problem.row_segment[velocity] == seg]
        rows = rows[~problem.row_after_rotation[rows]]
        for axis in range(3):
            sel = rows[axis::3]
            if len(sel) >= 4:
                sums.append(float(np.sum(rw[sel])) ** 2 / len(sel))
                expected.append(1.0 - float(np.sum(basis[sel].sum(axis=0) ** 2)) / len(sel))
    dof = float(np.sum(expected))
    return (float(np.sum(sums) / dof) if dof > 0 else 1.0), dof


def _fitted_noise(model: SensorNoise, noise_plan, factors: dict[str, float]) -> SensorNoise:
    """The noise the residuals imply: the model's white terms scaled by their kind's variance factor."""
    out = dataclasses.replace(model)
    out.accel_vrw = model.accel_vrw * np.sqrt(factors["velocity"])
    out.accel_quantization = model.accel_quantization * np.sqrt(factors["velocity"])
    out.gyro_arw = model.gyro_arw * np.sqrt(factors["gyro"])
    out.gyro_quantization = model.gyro_quantization * np.sqrt(factors["gyro"])
    return out
