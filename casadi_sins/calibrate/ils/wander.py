"""The ILS's bias instability without a datasheet: the wander its equations show.

The same restricted likelihood as the NLP's (:mod:`noise.wander`), on the equations: their covariance
is ``Sigma_white + sum_s s_s^2 Sigma_s`` with ``Sigma_s`` the equations' covariance under a unit
Gauss-Markov instability of sensor ``s`` (the exact covariance of :mod:`.covariance`, the correlation
time of :func:`calibrate.wander.wander_tau`).  With 48 equations and 21 parameters the contrasts are
27: the ILS sees a wander less surely than the NLP.  No mismatch guard: the ILS refuses a swaying
base and inflates its sigma by its variance factor.
"""

from __future__ import annotations

import numpy as np

from ...data.recording import Recording
from ...model.noise import SensorNoise
from ...model.registry import NATURAL_SCALE
from ...noise.plan import NoisePlan
from ...noise.wander import BiasWander, SensorWander
from ..wander import decide, unknown_sensors, wander_tau
from .covariance import equation_covariances


def unit_instability(sensor: str, tau: float) -> SensorNoise:
    """A noise model of nothing but a unit Gauss-Markov bias of ``sensor`` (1 m/s^2 or 1 rad/s)."""
    return SensorNoise(gyro_arw=0.0, accel_vrw=0.0, gyro_quantization=0.0, accel_quantization=0.0,
                       gyro_bias_instability=float(sensor == "gyro"), gyro_bias_tau=tau,
                       accel_bias_instability=float(sensor == "accel"), accel_bias_tau=tau)


def equation_bias_wander(rec: Recording, params: np.ndarray, navs, equations, noise_plan: NoisePlan, a: np.ndarray,
                         b: np.ndarray, covariance: np.ndarray, north_quadratic: bool = True
                         ) -> tuple[dict[str, SensorWander], np.ndarray | None]:
    """Bias instability of the sensors without a datasheet value from the equations ``a x = b`` (linearised
    at ``params``, white-noise ``covariance``).

    Returns ``(estimates, covariance with the included terms, or None when none is)``.
    """
    sensors = unknown_sensors(noise_plan)
    if not sensors:
        return {}, None
    tau = wander_tau(rec)
    units = dict(zip(sensors, equation_covariances(rec, params, navs, equations,
                                                   [unit_instability(s, tau) for s in sensors], north_quadratic)))
    chol = np.linalg.cholesky(covariance)
    whiten = np.linalg.solve(chol, np.eye(len(chol)))
    units_w = {s: whiten @ u @ whiten.T for s, u in units.items()}
    reml = BiasWander.from_covariances(whiten @ a * NATURAL_SCALE, whiten @ b, units_w, tau)
    estimates = decide(reml.estimate(sensors))
    included = [s for s, w in estimates.items() if w.included]
    if not included:
        return estimates, None
    return estimates, covariance + sum(estimates[s].sigma ** 2 * units[s] for s in included)
