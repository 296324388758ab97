"""The paper's reference solver: iterative linear least squares (Kang et al. 2013, section 1).

Each iteration:

1. navigate every group from its coarse alignment (eq. 14) with the current
   parameters;
2. in the static segment after each rotation, fit the north and east
   velocity errors with ``a + b tau + c tau^2`` and the up velocity error with
   ``a + b tau`` (``tau`` from the start of the segment); the linear and
   quadratic coefficients (north quadratic optional) are the equations,
   5 per rotation, 45 for the paper's 9 rotations; by default also the slope
   of the up velocity in each group's alignment segment, which the paper
   leaves unused (48 equations; ``paper_equations=True`` for exactly 45);
3. the same fits applied to the sensitivities of the velocity error to the
   21 error terms (``T_g, eps, T_a, Delta``), propagated through the linear
   error model (eqs. 13-21) along the navigated attitude with the alignment
   errors of eq. 15 (:mod:`nav.errormodel`), give the design matrix;
4. weighted least squares for the 21 errors, then the output model is
   corrected with eqs. 22-25, and the whole is repeated until every
   correction is below ``tolerance`` times its own sigma, or below
   :data:`ABSOLUTE_TOLERANCE` in natural units.

Weights: the noise of the equations is correlated across segments (the gyro noise tilts the whole
group's navigation, the coarse alignment carries the noise of its segment into every later one, bias
instability ties the recording together).  Their covariance under the sensor noise model (measured
in the raw data; the state-space model of :mod:`noise.kalman`, :mod:`.covariance`) weights a generalised least
squares, and ``sigma`` is its formal standard error, inflated by the residual variance factor only
when that exceeds its chi-square limit (48 - 21 = 27 degrees of freedom for the paper's schedule).
On a swaying base the method refuses: the coarse alignment assumes a still one.
"""


from __future__ import annotations

import dataclasses
import time
from typing import Callable

import numpy as np

from ...data.recording import Recording
from ...model.noise import SensorNoise
from ...model.output import apply_error_estimate
from ...model.parameters import ParameterSet
from ...model.registry import N_PARAMS, NAMES, NATURAL_SCALE, NATURAL_UNITS, SCALE_MASK
from ...noise.motion import describe_motion
from ...noise.plan import NoisePlan, plan_noise
from ..initial import rough_parameters
from ..limits import factor_limit, factor_low, separation_warnings
from ..result import Check, CalibrationError, CalibrationResult, IlsDetails, NoiseReport, outcome
from ..wander import bias_cost, describe, record, unknown_sensors, wander_tau, with_wander
from .covariance import equation_covariance
from .curvature import dimensionless_of, with_curvature
from .equations import build_equations, solve_equations
from .uncertainty import chi_square_factor, free_levels, noise_terms, sandwich, small_sample_factor
from .wander import equation_bias_wander

#: Corrections below these (natural units: ug, ppm, arcsec, deg/h) end the iteration regardless of sigma.
ABSOLUTE_TOLERANCE = np.where(np.isin(np.array(NATURAL_UNITS), ["deg/h"]), 1e-5, 1e-3)

#: The longest group the ILS takes: it holds per-sample sensitivities (21 per axis) and navigation states.
MAX_GROUP_SAMPLES = 1_500_000

#: What the ILS fits, in one line.
FITS = ("the ILS (the paper's method) fits the paper's 21 parameters (eq. 1) only; the extra groups (g-sensitivity, "
        "scale asymmetry, quadratic and cross-quadratic terms, lever arms, time offset) need the nlp solver")
SIGMA_MEANING = ("1-sigma of the generalised least squares of the last iteration under the equations' covariance "
                 "at that iteration from the sensor noise model (raw-data estimate, datasheet, white noise under "
                 "the pulses sized by the equations, bias wander of the static data), with the second order of "
                 "loosely determined combinations, times the variance factor when the residuals exceed it")


def calibrate_ils(rec: Recording, initial: ParameterSet | None = None, max_iterations: int = 10,
                  tolerance: float = 0.01, north_quadratic: bool = True, paper_equations: bool = False,
                  progress: Callable[[str], None] | None = None, noise: SensorNoise | None = None,
                  allow_base_motion: bool = False, model: str = "21") -> CalibrationResult:
    """Calibrate a recording with the paper's iterative least squares.

    Parameters
    ----------
    rec : Recording
    initial : ParameterSet, optional
        Starting values; default the paper's rough initial values (section 1.3).
    max_iterations : int
        Iteration cap (the paper needs 3; 4 with the confirming one).
    tolerance : float
        Stop when every correction is below ``tolerance`` times its sigma.
    north_quadratic : bool
        Use the north quadratic term (the paper allows leaving it out).
    paper_equations : bool
        Exactly the paper's 5 equations per rotation; by default the up-velocity slope of each
        group's alignment segment is added (see :func:`equations.build_equations`).
    progress : callable, optional
        Receives one line per iteration.
    noise : SensorNoise, optional
        Datasheet noise terms; the others are measured in the raw data (:func:`noise.plan.plan_noise`).
    allow_base_motion : bool
        Calibrate although the base sways (the result is then unreliable: see below).
    model : "21"
        The ILS fits the paper's 21 parameters only (:data:`FITS`); the extra groups need the NLP
        (``model="extended"`` or ``"auto"``).

    Raises
    ------
    CalibrationError
        When the base sways (the paper's coarse alignment needs a still base: a sway of 20 arcsec
        turns the aligned heading by degrees and tilts it by the sway's amplitude, which the method
        takes for sensor errors), the equations are rank deficient or the iteration does not converge.
    """
    _check_applicable(rec, model, progress)
    t_start = time.perf_counter()
    initial = initial or rough_parameters(rec)
    params = initial.core.copy()
    noise_plan = plan_noise(rec, params, noise)
    warnings = list(rec.warnings) + _base_motion_warning(noise_plan, allow_base_motion)
    history = [params.copy()]
    corrections = []
    covariance = None
    for iteration in range(1, max_iterations + 1):
        a, b, equations, navs = build_equations(rec, params, north_quadratic, alignment_up=not paper_equations)
        if covariance is None:  # the attitudes barely change between iterations
            covariance = equation_covariance(rec, params, navs, equations, noise_plan.model, north_quadratic)
        x, cov, factor = solve_equations(a, b, covariance)
        params = apply_error_estimate(params, x)
        history.append(params.copy())
        sigma = np.sqrt(np.diag(cov))
        ratio = np.abs(x) / np.where(sigma > 0, sigma, np.inf)
        corrections.append(x / NATURAL_SCALE)
        if progress:
            progress(_iteration_line(iteration, len(b), x, ratio, factor))
        if not np.all(np.isfinite(params)):
            raise CalibrationError(f"iteration {iteration} produced non-finite parameters")
        if np.all((ratio < tolerance) | (np.abs(x) / NATURAL_SCALE < ABSOLUTE_TOLERANCE)):
            break
    else:
        raise CalibrationError(f"the iterative least squares did not converge in {max_iterations} iterations "
                               f"(last corrections up to {np.max(ratio):.3g} sigma)")
    dof = len(b) - N_PARAMS
    paper_sigma = ParameterSet(params, covariance=_covariance_of_values(
        params, cov * _variance_factor(factor, dof, []))).natural_sigma()  # the paper's: the last solve's formal sigma
    final = _final_solve(rec, navs, equations, noise_plan, a, b, covariance, north_quadratic, history, corrections,
                         warnings, lambda p: build_equations(rec, p, north_quadratic, not paper_equations, False)[1])
    params, cov, factor, wander = final.params, final.covariance, final.factor, final.wander
    inflate = _variance_factor(factor, dof, warnings)
    result = ParameterSet(params, covariance=_covariance_of_values(params, cov * inflate))
    checks = _checks(result, factor, len(b), noise_plan, warnings, wander, final)
    status, message = outcome(warnings, iteration)
    return CalibrationResult(result, "ils", True, status, message, iteration, initial, history,
                             float(np.sqrt(factor)), time.perf_counter() - t_start, SIGMA_MEANING, warnings, checks,
                             inflate, NoiseReport(with_wander(noise_plan.model, wander) or noise_plan.model,
                                                  noise_plan.raw, None, dict(noise_plan.source), wander),
                             noise_plan.motions,
                             ils=IlsDetails(len(b), [eq.label for eq in equations], corrections, paper_sigma,
                                            final.free_levels, final.curvature),
                             linear_motion=noise_plan.linear)


def _iteration_line(iteration: int, equations: int, x: np.ndarray, ratio: np.ndarray, factor: float) -> str:
    """One line of progress: the largest correction of an iteration in natural units and sigma."""
    worst = int(np.argmax(ratio))
    return (f"ils iteration {iteration}: {equations} equations, largest correction {NAMES[worst]} "
            f"{x[worst] / NATURAL_SCALE[worst]:+.4g} {NATURAL_UNITS[worst]} ({ratio[worst]:.3g} sigma), "
            f"variance factor {factor:.3g}")


@dataclasses.dataclass
class _Final:
    """The last solve under the noise model of the last iteration (:func:`_final_solve`)."""

    params: np.ndarray
    covariance: np.ndarray  # of the error terms (SI, scale factors relative)
    factor: float
    wander: dict
    free_levels: dict
    curvature: float


def _final_solve(rec: Recording, navs, equations, noise_plan: NoisePlan, a: np.ndarray, b: np.ndarray,
                 weights: np.ndarray, north_quadratic: bool, history: list, corrections: list,
                 warnings: list[str], rhs: Callable[[np.ndarray], np.ndarray]) -> _Final:
    """The noise model at the last linearisation (:mod:`.uncertainty`): the white terms the raw data left to the
    fit sized by the equations' restricted likelihood, the bias instability the equations show without a
    datasheet (:mod:`.wander`).  When either entered, the last solve is made again under the model
    (``history`` and ``corrections`` updated, the noise plan records the terms, ``warnings`` gets the wander's
    warning); otherwise the solve's values stay and their covariance is the sandwich under the final model.
    Second order is added where the loose combinations reach the tight ones (:mod:`.curvature`)."""
    sensors = unknown_sensors(noise_plan)
    terms = noise_terms(rec, history[-2], navs, equations, noise_plan, sensors, wander_tau(rec), north_quadratic)
    bounds = noise_plan.raw.upper_bounds()
    levels = free_levels(a, b, terms, {t: float(np.max(getattr(bounds, t))) for t in terms.free})
    for term, level in levels.items():
        setattr(noise_plan.model, term, np.full(3, level))
    white = terms.covariance(levels)
    wander, total = equation_bias_wander(rec, history[-2], navs, equations, noise_plan, a, b, white,
                                         north_quadratic, terms.wander)
    if total is not None:
        record(noise_plan, wander)
    model = white if total is None else total
    used = weights
    if total is not None or levels:  # a model the weights did not have: solve again under it
        used = model
        x, cov, factor = solve_equations(a, b, model)
        for sensor, estimate in wander.items():
            if estimate.included:
                estimate.cost = bias_cost(sandwich(a, white, white), cov, NAMES, sensor)
        cov = cov * small_sample_factor(len(b) - N_PARAMS, levels)
        if describe(wander):
            warnings.append(describe(wander))
        history[-1] = apply_error_estimate(history[-2], x)
        corrections[-1] = x / NATURAL_SCALE
    else:
        x = corrections[-1] * NATURAL_SCALE
        cov, factor = sandwich(a, weights, model), chi_square_factor(a, b, x, model)
    cov, share = with_curvature(rhs, history[-2], b, a, used, cov, dimensionless_of(rec))
    return _Final(history[-1], cov, factor, wander, levels, share)


def _checks(result: ParameterSet, factor: float, equations: int, noise_plan: NoisePlan, warnings: list[str],
            wander: dict, final: _Final | None = None) -> list[Check]:
    """The equations' chi-square (two-sided; their residuals over the noise model, as the NLP's residual checks
    say it), the second order of the linearisation, and the separability checks; their warnings into
    ``warnings``."""
    dof = equations - N_PARAMS
    low, limit = factor_low(dof), factor_limit(dof)
    sized = "".join(f"; {t} sized by the equations' restricted likelihood" for t in (final.free_levels if final else {}))
    checks = [Check("equations vs noise model", factor, limit, low <= factor <= limit,
                    f"chi-square per degree of freedom of the {equations} equations ({dof} degrees of freedom): "
                    f"residuals {np.sqrt(factor):.3g} times the noise model at the last iteration (noise from "
                    f"{noise_plan.source['accel_vrw']} / {noise_plan.source['gyro_arw']}{sized})", low)]
    if final is not None and final.curvature > 0.0:
        checks.append(Check("second order of the linearisation", final.curvature, 1.0, True,
                            "largest share of a parameter's variance from the curvature of the equations across the "
                            "loosely determined combinations (the alignment of few groups), included in sigma", 0.0))
    separation_checks, separation_text = separation_warnings(result, wander)
    warnings += noise_plan.warnings + separation_text
    return checks + separation_checks


def _check_applicable(rec: Recording, model, progress=None) -> None:
    """Refuse what the paper's method cannot do: the extended model, groups too long to hold in memory;
    say what it fits (:data:`FITS`)."""
    if progress:
        progress(f"ils: {FITS}")
    if model not in ("21", None, ()):
        raise CalibrationError(f"{FITS}; use the nlp solver for the extended model")
    longest = max(rec.group_samples(g).stop - rec.group_samples(g).start for g in rec.group_ids)
    if longest > MAX_GROUP_SAMPLES:
        raise CalibrationError(f"a group of {longest} samples: the ILS keeps the error model's sensitivities of every "
                               f"sample (about 5 kB each), more than {MAX_GROUP_SAMPLES} samples would need "
                               f"{longest * 5e3 / 1e9:.0f} GB; the nlp solver handles long files")


def _base_motion_warning(noise_plan: NoisePlan, allow_base_motion: bool) -> list[str]:
    """A moving base (sway, or a deck's heave and surge): refuse (the coarse alignment and the velocity equations
    need a still one), or warn when allowed."""
    motion = "; ".join(m for m in (describe_motion(noise_plan.motions),
                                   noise_plan.linear.describe() if noise_plan.linear is not None else None) if m)
    if not motion:
        return []
    if not allow_base_motion:
        raise CalibrationError(f"{motion}; the paper's method aligns each group on a still base and would take the "
                               "base's motion for sensor errors: use the nlp solver, which estimates the start "
                               "attitudes and takes the motion out (docs/moving-base.md)")
    return [f"{motion}: the paper's method assumes a still base; this table is unreliable"]


def _variance_factor(factor: float, dof: int, warnings: list[str]) -> float:
    """The factor applied to the covariance: the equations' own, only beyond its chi-square limit.

    White noise the raw data could not show (coarse pulses) stays at its upper bound: conservative.
    Scaling it by the equations' own variance factor (27 degrees of freedom) was measured to be
    overconfident in 4 of 50 runs (beyond 4.5 sigma), the bound is not.
    """
    if factor < factor_low(dof):
        warnings.append(f"the equations' residuals are {1 / np.sqrt(max(factor, 1e-300)):.3g} times smaller than the "
                        f"sensor noise ({dof} degrees of freedom): the noise model is too large")
        return 1.0
    if factor <= factor_limit(dof):
        return 1.0
    warnings.append(f"the equations' residuals are {np.sqrt(factor):.3g} times the sensor noise ({dof} degrees "
                    f"of freedom): errors outside the model; sigma inflated by {np.sqrt(factor):.3g}")
    return factor


def _covariance_of_values(params: np.ndarray, error_cov: np.ndarray) -> np.ndarray:
    """Covariance of the parameter values from that of the error terms (scale: S = S_hat/(1+t))."""
    jac = np.ones(N_PARAMS)
    jac[SCALE_MASK] = -params[SCALE_MASK]
    return error_cov * np.outer(jac, jac)
