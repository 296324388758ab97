"""The ILS's covariance at its last iteration, under the noise model its own equations support.

The weights of the ILS's solves are the equations' covariance under the noise plan at the first iteration
(:mod:`.covariance`).  Its sigma is that of the values it returns, under the noise model as it stands at the
last iteration:

* **at the last linearisation**: the equations' covariance along the last navigation, one pass for every
  term (:func:`noise_terms`): the fixed white noise and quantization, a unit of each white term the raw data
  did not determine, a unit instability of each sensor without a datasheet value;
* **the white noise hidden under coarse pulses** (the plan's ``"fit"`` terms, at the raw data's upper bound
  in the weights) sized by restricted maximum likelihood of the equations' residuals (:func:`free_levels`),
  between the noise floors and those bounds: the ILS's counterpart of the NLP's
  :func:`calibrate.nlp.likelihood.estimate_free_terms`;
* **the covariance of the values** the solve returned: ``G Sigma G^T`` with ``G = (A^T W A)^-1 A^T W`` the
  generalised least squares of the solve (:func:`sandwich`), which is the solve's formal covariance when
  its weights are the final model, and stays honest when they are not (the values of the paper's recording
  keep their first-iteration weights);
* **second order** (:mod:`.curvature`): where the loose combinations are so wide that the curvature of the
  equations across them reaches the tight ones.

The same before any data, on a schedule: :mod:`.predicted`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...model.noise import ACCEL_VRW_FLOOR, GYRO_ARW_FLOOR, SensorNoise
from ...model.registry import NATURAL_SCALE
from ...noise.plan import NoisePlan
from .covariance import equation_covariances
from .wander import unit_instability

#: The white terms the raw data may leave to the fit, and their floors.
FREE_FLOORS = {"gyro_arw": GYRO_ARW_FLOOR, "accel_vrw": ACCEL_VRW_FLOOR}


@dataclasses.dataclass
class NoiseTerms:
    """The equations' covariance by term at one linearisation.

    Attributes
    ----------
    fixed : ndarray (m, m)
        Under the noise model's terms that are known (datasheet, raw data, a counter's quantization).
    free : dict
        White term the fit sets (``"gyro_arw"``, ``"accel_vrw"``) -> its covariance at a unit level (one
        level for the three axes).
    wander : dict
        Sensor (``"accel"``, ``"gyro"``) -> the covariance under a unit Gauss-Markov instability.
    """

    fixed: np.ndarray
    free: dict[str, np.ndarray]
    wander: dict[str, np.ndarray]

    def covariance(self, levels: dict[str, float], sizes: dict[str, float] | None = None) -> np.ndarray:
        """``fixed + sum level^2 free + sum size^2 wander``."""
        out = self.fixed + sum(levels[t] ** 2 * u for t, u in self.free.items())
        return out + sum(s**2 * self.wander[k] for k, s in (sizes or {}).items())


def free_terms(noise_plan: NoisePlan) -> list[str]:
    """The white terms the raw data did not determine (the plan's ``"fit"``)."""
    return [t for terms in noise_plan.free_terms().values() for t in terms]


def noise_terms(rec, params: np.ndarray, navs, equations, noise_plan: NoisePlan, sensors: list[str], tau: float,
                north_quadratic: bool) -> NoiseTerms:
    """The equations' covariance of every term in one pass (:class:`NoiseTerms`): ``sensors`` without a
    datasheet's instability get a unit Gauss-Markov term of correlation time ``tau``."""
    free = free_terms(noise_plan)
    fixed = dataclasses.replace(noise_plan.model, **{t: np.zeros(3) for t in free})
    units = [_unit_white(t) for t in free]
    markov = [unit_instability(s, tau) for s in sensors]
    noise = fixed.complete()
    if markov and not (noise.gyro_bias_instability or noise.accel_bias_instability):
        models = markov + [fixed] + units  # the first model sets the transitions
        out = equation_covariances(rec, params, navs, equations, models, north_quadratic)
        wander, rest = out[:len(markov)], out[len(markov):]
    else:  # a datasheet's instability sets the transitions; no sensor is left to measure (or none asked for)
        rest = equation_covariances(rec, params, navs, equations, [fixed] + units, north_quadratic)
        wander = []
        if markov:
            wander = equation_covariances(rec, params, navs, equations, markov, north_quadratic)
    return NoiseTerms(rest[0], dict(zip(free, rest[1:])), dict(zip(sensors, wander)))


def _unit_white(term: str) -> SensorNoise:
    """A noise model of nothing but a unit level of one white term on the three axes."""
    zero = np.zeros(3)
    values = {"gyro_arw": zero, "accel_vrw": zero, "gyro_quantization": zero, "accel_quantization": zero,
              "gyro_bias_instability": 0.0, "accel_bias_instability": 0.0}
    return SensorNoise(**(values | {term: np.ones(3)}))


def small_sample_factor(dof: int, levels: dict) -> float:
    """The variance of an error over a sigma whose noise level the same equations set: ``dof / (dof - 2)``
    (Student's t with the equations' ``dof`` contrasts; 1.08 for the paper's 27) when white terms were sized
    by them (``levels``), else 1.  Without it the joint chi-square of 20 runs of a coarse counter whose pulses
    hide the white noise read 489 for 420 (band 365-479)."""
    return dof / (dof - 2.0) if levels and dof > 4 else 1.0


def restricted_nll(a: np.ndarray, b: np.ndarray, covariance: np.ndarray) -> float:
    """Negative restricted log-likelihood of the equations ``a x = b`` under ``covariance`` (parameters
    profiled out, their degrees of freedom taken off; up to a constant)."""
    chol = np.linalg.cholesky(covariance)
    aw = np.linalg.solve(chol, a * NATURAL_SCALE)
    bw = np.linalg.solve(chol, b)
    q, r = np.linalg.qr(aw)
    rest = bw - q @ (q.T @ bw)
    return float(np.sum(np.log(np.diag(chol))) + 0.5 * rest @ rest + np.sum(np.log(np.abs(np.diag(r)))))


def free_levels(a: np.ndarray, b: np.ndarray, terms: NoiseTerms, bounds: dict[str, float],
                sizes: dict[str, float] | None = None) -> dict[str, float]:
    """The levels of the free white terms by restricted maximum likelihood of the equations' residuals,
    between their floors and ``bounds`` (the raw data's upper bounds): ``{term: level}`` (SI, the same on
    the three axes; empty when there is none)."""
    names = list(terms.free)
    if not names:
        return {}
    low = np.log([FREE_FLOORS[t] for t in names])
    high = np.log([max(bounds[t], 10.0 * FREE_FLOORS[t]) for t in names])

    def nll(theta):
        return restricted_nll(a, b, terms.covariance(dict(zip(names, np.exp(theta))), sizes))

    from scipy.optimize import minimize  # imported here: most calibrations have no free term

    result = minimize(nll, high - 0.5, method="Nelder-Mead", bounds=list(zip(low, high)),
                      options={"xatol": 0.01, "fatol": 0.01, "maxfev": 200 * len(names)})
    return dict(zip(names, np.exp(result.x)))


def gls_operator(a: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``G = (A^T W A)^-1 A^T W`` (21, m): the SI error terms per unit of the right-hand side (natural
    scaling inside)."""
    chol = np.linalg.cholesky(weights)
    aw = np.linalg.solve(chol, a * NATURAL_SCALE)
    u, s, vt = np.linalg.svd(aw, full_matrices=False)
    return NATURAL_SCALE[:, None] * ((vt.T / s) @ u.T @ np.linalg.inv(chol))


def sandwich(a: np.ndarray, weights: np.ndarray, covariance: np.ndarray) -> np.ndarray:
    """Covariance (SI error terms) of the generalised least squares under ``weights`` when the equations'
    covariance is ``covariance``: ``G Sigma G^T`` (:func:`gls_operator`)."""
    g = gls_operator(a, weights)
    cov = g @ covariance @ g.T
    return 0.5 * (cov + cov.T)


def chi_square_factor(a: np.ndarray, b: np.ndarray, x: np.ndarray, covariance: np.ndarray) -> float:
    """The residuals' chi-square per degree of freedom under ``covariance`` (``x`` the solve's SI errors)."""
    residual = b - a @ x
    white = np.linalg.solve(np.linalg.cholesky(covariance), residual)
    return float(white @ white) / max(len(b) - a.shape[1], 1)

