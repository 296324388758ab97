"""Consistency checks of the NLP's fit against its noise model, and the honest variance factor.

Under a right noise model the Kalman-whitened residuals (:mod:`noise.kalman`) are independent with
unit variance, whatever the sensor.  Each check compares a statistic of them with its distribution
under that hypothesis (:mod:`calibrate.limits`).  A failed check writes a warning and, where it means
the residuals are larger than the model says, multiplies the covariance by the observed variance
factor: the sigma is then that of the data, not of the model.

Checks
    * velocity and gyro-mean residuals against the noise model (variance factor per kind);
    * drift within static segments (low-frequency excess: bias instability, thermal drift);
    * whiteness (lag-one correlation of consecutive innovations);
    * each group's chi-square;
    * the velocity steps across rotations against the static residuals;
    * the Gauss-Newton steps after Ipopt (converged, and how far they moved).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...model.noise import SensorNoise
from ...noise.observations import ObservationKind
from ...noise.plan import NoisePlan
from ..limits import Z_LIMIT, factor_limit, factor_low
from ..result import Check
from .gls import GLS_LINEAR_STEP, Fit
from .graph import ResidualGraph

#: Mean square of the whitened residuals after rotations over that of the others, above which the steps
#: are taken as unmodelled (F-test: the 99.9 % point for 27 against 3500 degrees of freedom is 2.0).
STEP_CONSISTENCY_LIMIT = 3.0


@dataclasses.dataclass
class Assessment:
    """The checks of a fit, the warnings they raise, and the variance factor to apply."""

    checks: list[Check] = dataclasses.field(default_factory=list)
    warnings: list[str] = dataclasses.field(default_factory=list)
    factors: dict[str, float] = dataclasses.field(default_factory=dict)
    variance_factor: float = 1.0
    fitted_noise: SensorNoise | None = None
    too_good: dict[str, float] = dataclasses.field(default_factory=dict)  # kinds whose residuals are far below
    model_fails: bool = False  # residuals beyond the model: velocity, gyro, drift or rotation-step check failed

    def add(self, check: Check, warning: str | None = None, inflate: float | None = None,
            beyond_model: bool = False) -> None:
        """Record a check; when it failed, its warning, the inflation it asks for, and whether the residuals
        exceed the model."""
        self.checks.append(check)
        if check.passed:
            return
        if warning:
            self.warnings.append(warning)
        if inflate is not None:
            self.variance_factor = max(self.variance_factor, inflate)
        self.model_fails |= beyond_model


def assess(graph: ResidualGraph, fit: Fit, noise_plan: NoisePlan) -> Assessment:
    """Run every check on a finished fit (see the module docstring)."""
    out = Assessment()
    _kind_factors(out, graph, fit, noise_plan)
    _drift(out, graph, fit)
    _whiteness(out, graph, fit.whitened_residuals)
    _group_chi_square(out, graph, fit)
    if fit.use_rotation_steps:
        ratio = fit.rotation_step_ratio
        out.add(Check("velocity steps across rotations", ratio, STEP_CONSISTENCY_LIMIT, ratio <= STEP_CONSISTENCY_LIMIT,
                      f"variance ratio {ratio:.3g}: mean square of the whitened residuals after rotations over "
                      "that of the others"),
                f"the velocity steps across rotations fit worse than the static residuals (variance ratio "
                f"{ratio:.3g}, RMS {np.sqrt(ratio):.3g} times): terms outside the model act during the rotations",
                beyond_model=True)
    steps = fit.gls_steps
    out.add(Check("post-solve steps converged", steps[-1], GLS_LINEAR_STEP, steps[-1] < GLS_LINEAR_STEP,
                  f"generalised least-squares steps after Ipopt: {', '.join(f'{s:.3g}' for s in steps)} sigma "
                  "(the last one, in the linear region, is applied without another evaluation)"),
            f"the generalised least squares did not settle (last step {steps[-1]:.3g} sigma)")
    out.fitted_noise = fitted_noise(fit.noise, out.factors)
    if len(out.too_good) == len(out.factors) and out.variance_factor == 1.0:
        # every kind's residuals far below the model: the model is too large, the data say by how much
        out.variance_factor = max(out.too_good.values())
        out.warnings.append(f"sigma scaled down by {np.sqrt(out.variance_factor):.3g} to the residuals' own noise")
    return out


def _source_of(noise_plan: NoisePlan, label: str, free: list[str]) -> str:
    """Where the white noise of a residual kind came from, for the check's detail."""
    if free:
        return f"{', '.join(free)} set by the fit within the raw data's bound"
    term = "accel_vrw" if label == "velocity" else "gyro_arw"
    return noise_plan.source.get(term, "raw data")


def _kind_factors(out: Assessment, graph: ResidualGraph, fit: Fit, noise_plan: NoisePlan) -> None:
    """Velocity and gyro-mean residuals against the noise model."""
    rw, leverage = fit.whitened_residuals, fit.leverage
    # once errors outside the model were given a place in it, its size is the fit's own (REML): no lower limit
    two_sided = not (fit.noise.unmodelled_acceleration or fit.noise.unmodelled_rate or fit.noise.unmodelled_step)
    for label, kind in (("velocity", ObservationKind.VELOCITY), ("gyro", ObservationKind.GYRO_MEAN)):
        rows = graph.observations.rows_of(kind)
        dof = float(rows.sum() - leverage[rows].sum())
        factor = float(np.sum(rw[rows] ** 2) / dof) if dof > 0.5 else 1.0
        out.factors[label] = factor
        free = noise_plan.free_terms()[label]
        limit, low = factor_limit(dof), factor_low(dof) if two_sided else 0.0
        source = _source_of(noise_plan, label, free)
        detail = (f"variance ratio {factor:.3g}: mean square of the whitened {label} residuals per degree of "
                  f"freedom ({dof:.0f}), 1 when the noise model is right (noise from {source})")
        check = Check(f"{label} residuals vs noise model", factor, limit, low <= factor <= limit, detail, low)
        if factor > limit:
            out.add(check, f"the {label} residuals' variance is {factor:.3g} times the sensor noise's ({source}; RMS "
                    f"{np.sqrt(factor):.3g} times): errors outside the model (model mismatch, base motion, drift); "
                    f"sigma inflated by {np.sqrt(factor):.3g}", inflate=factor, beyond_model=True)
        else:
            out.add(check, f"the {label} residuals' variance is {factor:.3g} times the sensor noise's ({source}; RMS "
                    f"{np.sqrt(factor):.3g} times): the noise model is too large (a datasheet above the unit's noise, "
                    "or a counter's quantization taken for white noise?)")
            if factor < low:
                out.too_good[label] = factor


def _drift(out: Assessment, graph: ResidualGraph, fit: Fit) -> None:
    """Drift within static segments."""
    low, dof = drift_statistic(graph, fit.whitened_residuals, fit.left_singular_vectors)
    if dof <= 0:
        return
    limit = factor_limit(dof)
    out.add(Check("drift within static segments", low, limit, low <= limit,
                  f"mean square of the segment sums of whitened velocity residuals ({dof:.0f} degrees of freedom "
                  "after the fit; 1 without drift)"),
            f"the velocity drifts within static segments {np.sqrt(low):.3g} times more than the noise model allows: "
            "bias instability or thermal drift not in the model (give the datasheet's bias instability); sigma "
            f"inflated by {np.sqrt(low):.3g}", inflate=low, beyond_model=True)


def _velocity_rows_by_segment(graph: ResidualGraph):
    """``(segment, velocity rows)`` per static segment."""
    table = graph.observations
    velocity = np.flatnonzero(table.rows_of(ObservationKind.VELOCITY))
    for seg in np.unique(table.segment[velocity]):
        yield seg, velocity[table.segment[velocity] == seg]


def _whiteness(out: Assessment, graph: ResidualGraph, rw: np.ndarray) -> None:
    """Lag-one correlation of consecutive velocity innovations of one axis."""
    pairs = []
    for _, rows in _velocity_rows_by_segment(graph):
        for axis in range(3):
            sel = rows[axis::3]
            pairs.append(np.column_stack([rw[sel][:-1], rw[sel][1:]]))
    pairs = np.vstack(pairs) if pairs else np.zeros((0, 2))
    if len(pairs) <= 10:
        return
    rho = float(np.sum(pairs[:, 0] * pairs[:, 1]) / np.sqrt(np.sum(pairs[:, 0] ** 2) * np.sum(pairs[:, 1] ** 2)))
    limit = Z_LIMIT / np.sqrt(len(pairs)) + 0.1
    out.add(Check("whiteness (lag-one correlation)", rho, limit, abs(rho) <= limit,
                  f"correlation of consecutive whitened velocity residuals, {len(pairs)} pairs", low=-limit),
            f"consecutive velocity residuals are correlated ({rho:+.2f}): the noise is not the modelled one "
            "(vibration, unmodelled motion)")


def _group_chi_square(out: Assessment, graph: ResidualGraph, fit: Fit) -> None:
    """Chi-square of each group; a warning when one group fits much worse than the rest."""
    rw, leverage = fit.whitened_residuals, fit.leverage
    two_sided = not (fit.noise.unmodelled_acceleration or fit.noise.unmodelled_rate or fit.noise.unmodelled_step)
    for group in np.unique(graph.observations.group):
        rows = graph.observations.group == group
        dof = float(rows.sum() - leverage[rows].sum())
        factor = float(np.sum(rw[rows] ** 2) / max(dof, 1.0))
        limit, low = factor_limit(dof), factor_low(dof) if two_sided else 0.0
        worse = factor > max(out.factors.values()) * 1.2
        out.add(Check(f"group {group} chi-square", factor, limit, low <= factor <= limit,
                      f"whitened residuals of group {group}, {dof:.0f} degrees of freedom", low),
                (f"group {group} fits {np.sqrt(factor):.3g} times worse than the noise: a disturbance in that group "
                 "(handling, shock)?") if worse and factor > limit else None)


def drift_statistic(graph: ResidualGraph, rw: np.ndarray, basis: np.ndarray) -> tuple[float, float]:
    """Drift within static segments: mean square of the segment sums of whitened velocity residuals.

    A slow error (bias instability, drift, an unmodelled slope) makes the sums of consecutive
    innovations large.  The fitted parameters take out part of every sum (its leverage), so
    ``E[sum^2 / n] = 1 - ||U^T a||^2`` with ``U`` the left singular vectors of the whitened Jacobian.
    Returns ``(statistic, expected sum)``; the statistic is 1 without drift.
    """
    sums, expected = [], []
    after = graph.observations.after_rotation
    for _, rows in _velocity_rows_by_segment(graph):
        rows = rows[~after[rows]]
        for axis in range(3):
            sel = rows[axis::3]
            if len(sel) >= 4:
                sums.append(float(np.sum(rw[sel])) ** 2 / len(sel))
                expected.append(1.0 - float(np.sum(basis[sel].sum(axis=0) ** 2)) / len(sel))
    dof = float(np.sum(expected))
    return (float(np.sum(sums) / dof) if dof > 0 else 1.0), dof


def fitted_noise(model: SensorNoise, factors: dict[str, float]) -> SensorNoise:
    """The noise the residuals imply: the model's white terms scaled by their kind's variance factor."""
    out = dataclasses.replace(model)
    out.accel_vrw = model.accel_vrw * np.sqrt(factors["velocity"])
    out.accel_quantization = model.accel_quantization * np.sqrt(factors["velocity"])
    out.gyro_arw = model.gyro_arw * np.sqrt(factors["gyro"])
    out.gyro_quantization = model.gyro_quantization * np.sqrt(factors["gyro"])
    return out
