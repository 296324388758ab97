"""The NLP's bias instability without a datasheet: the wander its residuals show, and the guard against a
misfit that is no wander.

At the fit's solution the bias responses of the pieces (:mod:`noise.pieces`) are whitened by the same
filter and noise model as the residuals and the Jacobian of its last pass, and the restricted likelihood
(:mod:`noise.wander`) sizes each sensor's wander.  The same machinery fits an acceleration constant in
each static segment and independent between segments (what the unmodelled acceleration of
:mod:`.likelihood` stands for): when that explains the misfit decisively better than a wander, it is
model mismatch (lever arms, a quadratic scale factor), left to the checks of :mod:`.diagnostics`.
"""

from __future__ import annotations

from ...data.recording import Recording
from ...noise.pieces import whitened_bias_responses
from ...noise.plan import NoisePlan
from ...noise.wander import BiasWander, SensorWander
from ..wander import MISMATCH_LR, decide, piece_s, unknown_sensors, wander_tau
from .gls import Fit


def estimate_bias_wander(rec: Recording, fit: Fit, noise_plan: NoisePlan) -> dict[str, SensorWander]:
    """Bias instability of the sensors without a datasheet value, from the fit's residuals (module
    docstring); each :class:`noise.wander.SensorWander` marked included (or left out as a mismatch) by
    :func:`calibrate.wander.decide`.  Empty when every sensor has its datasheet value."""
    sensors = unknown_sensors(noise_plan)
    if not sensors:
        return {}
    zw, pieces = whitened_bias_responses(fit.system, fit.noise, piece_s(rec))
    reml = BiasWander.from_responses(fit.whitened_residuals, fit.left_singular_vectors, zw, pieces,
                                     wander_tau(rec))
    estimates = reml.estimate(sensors)
    if not any(w.sigma > 0.0 for w in estimates.values()):
        return decide(estimates)
    competitor = reml.estimate(["segment"])["segment"]
    smooth = reml.nll({s: w.sigma for s, w in estimates.items()})
    rough = reml.nll({"segment": competitor.sigma})
    return decide(estimates, mismatch=2.0 * (smooth - rough) > MISMATCH_LR)
