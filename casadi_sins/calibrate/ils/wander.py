"""The ILS's bias instability without a datasheet: the wander its equations show.

The same restricted likelihood as the NLP's (:mod:`noise.wander`), on the equations: their covariance
is ``Sigma_white + sum_s s_s^2 Sigma_s`` with ``Sigma_s`` the equations' covariance under a unit
Gauss-Markov instability of sensor ``s`` (the exact covariance of :mod:`.covariance`, the correlation
time of :func:`calibrate.wander.wander_tau`).  With 48 equations and 21 parameters the contrasts are
27: the ILS sees a wander less surely than the NLP.  The same guard as the NLP's against a misfit that
is no wander: an accelerometer offset constant in each static segment and independent between segments
(the accelerometer-bias columns of each segment's equations) competes with the wander, and when it
explains the misfit better by :data:`calibrate.wander.MISMATCH_LR` no term is included (lever arms or a
quadratic scale factor: the equations' chi-square check then fails and the variance factor widens the
sigma, with the warning that names errors outside the model).
"""

from __future__ import annotations

import numpy as np

from ...data.recording import Recording
from ...model.noise import SensorNoise
from ...model.registry import NAMES
from ...noise.plan import NoisePlan
from ...noise.wander import BiasWander, SensorWander
from ..wander import MISMATCH_LR, decide, unknown_sensors, wander_tau
from .covariance import equation_covariances


def unit_instability(sensor: str, tau: float) -> SensorNoise:
    """A noise model of nothing but a unit Gauss-Markov bias of ``sensor`` (1 m/s^2 or 1 rad/s)."""
    return SensorNoise(gyro_arw=0.0, accel_vrw=0.0, gyro_quantization=0.0, accel_quantization=0.0,
                       gyro_bias_instability=float(sensor == "gyro"), gyro_bias_tau=tau,
                       accel_bias_instability=float(sensor == "accel"), accel_bias_tau=tau)


def equation_bias_wander(rec: Recording, params: np.ndarray, navs, equations, noise_plan: NoisePlan, a: np.ndarray,
                         b: np.ndarray, covariance: np.ndarray, north_quadratic: bool = True,
                         units: dict[str, np.ndarray] | None = None
                         ) -> tuple[dict[str, SensorWander], np.ndarray | None]:
    """Bias instability of the sensors without a datasheet value from the equations ``a x = b`` (linearised
    at ``params``, white-noise ``covariance``); ``units`` (sensor -> the equations' covariance under a unit
    instability) when already computed.

    Returns ``(estimates, covariance with the included terms, or None when none is)``.
    """
    sensors = unknown_sensors(noise_plan)
    if not sensors:
        return {}, None
    tau = wander_tau(rec)
    if units is None:
        units = dict(zip(sensors, equation_covariances(rec, params, navs, equations,
                                                       [unit_instability(s, tau) for s in sensors], north_quadratic)))
    chol = np.linalg.cholesky(covariance)
    whiten = np.linalg.solve(chol, np.eye(len(chol)))
    units_w = {s: whiten @ u @ whiten.T for s, u in (units | {"segment": segment_offsets(a, equations)}).items()}
    reml = BiasWander.from_covariances(whiten @ a, whiten @ b, units_w, tau)  # columns normalised there
    estimates = reml.estimate(sensors)
    if any(w.sigma > 0.0 for w in estimates.values()):
        competitor = reml.estimate(["segment"])["segment"]
        smooth = reml.nll({s: w.sigma for s, w in estimates.items()})
        rough = reml.nll({"segment": competitor.sigma})
        estimates = decide(estimates, mismatch=2.0 * (smooth - rough) > MISMATCH_LR)
    else:
        estimates = decide(estimates)
    included = [s for s, w in estimates.items() if w.included]
    if not included:
        return estimates, None
    return estimates, covariance + sum(estimates[s].sigma ** 2 * units[s] for s in included)


def segment_offsets(a: np.ndarray, equations) -> np.ndarray:
    """The equations' covariance (m, m) under an accelerometer offset of unit variance per axis, constant in
    each static segment and independent between segments: ``sum_s A_s A_s^T`` with ``A_s`` the
    accelerometer-bias columns of ``a`` on the rows of segment ``s`` (the competitor of the mismatch guard)."""
    columns = a[:, [NAMES.index(f"accel_bias_{axis}") for axis in "xyz"]]
    out = np.zeros((len(equations), len(equations)))
    keys = [(eq.group, eq.segment) for eq in equations]
    for key in set(keys):
        rows = np.array([k == key for k in keys])
        block = np.where(rows[:, None], columns, 0.0)
        out += block @ block.T
    return out
