"""Noise levels from a fit: restricted maximum likelihood through the Kalman filter.

Terms the raw data did not determine (white noise hidden under coarse pulses) and the errors outside
the model (when a fit's checks fail) take the values that maximise the restricted likelihood of the
fit's residuals, linearised at its solution: the filter gives ``log det Sigma`` and the whitened
residuals, the parameters are profiled out and their degrees of freedom taken off (REML).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...model.noise import ACCEL_VRW_FLOOR, GYRO_ARW_FLOOR, SensorNoise
from ...noise.kalman import NoiseSystem
from ...noise.observations import ObservationKind, ObservationTable
from ...noise.plan import NoisePlan

#: Search ranges of the unmodelled terms: acceleration (m/s^2), rate (rad/s), for a navigation-grade unit; the
#: tops grow to :data:`UNMODELLED_HEADROOM` times the fit's own residuals when those are larger (a MEMS unit).
UNMODELLED_ACCELERATION_RANGE = (1e-8, 1e-2)
UNMODELLED_RATE_RANGE = (1e-12, 1e-5)
UNMODELLED_STEP_RANGE = (1e-7, 1.0)
UNMODELLED_HEADROOM = 100.0


def restricted_likelihood(system: NoiseSystem, columns: np.ndarray, model: SensorNoise) -> float:
    """Negative restricted log-likelihood of residuals linearised at a fit (``columns`` = [r, J]).

    The Kalman filter gives ``log det Sigma`` and the whitened columns; the parameters are profiled out
    (generalised least squares) and their degrees of freedom taken off (REML).
    """
    white = system.whiten(columns, model)
    rw, jw = white.columns[:, 0], white.columns[:, 1:]
    q, rr = np.linalg.qr(jw)
    rest = rw - q @ (q.T @ rw)
    return 0.5 * (white.log_det + float(rest @ rest)) + float(np.sum(np.log(np.abs(np.diag(rr)))))


def estimate_terms(system: NoiseSystem, columns: np.ndarray, base: SensorNoise,
                   terms: dict[str, tuple[float, float, float]]) -> SensorNoise:
    """Noise terms by restricted maximum likelihood (Nelder-Mead in log scale).

    ``terms`` maps a :class:`SensorNoise` field to ``(start, low, high)``; per-axis fields are scaled as a
    whole (their shape across axes is kept from ``base`` where it is not zero).
    """
    names = list(terms)
    shapes = {}
    for name in names:
        value = np.asarray(getattr(base, name), dtype=float)
        shapes[name] = value / value.max() if value.ndim and value.max() > 0 else np.ones(value.shape)

    def model_of(theta):
        out = dataclasses.replace(base)
        for name, t in zip(names, theta):
            level = float(np.exp(t))
            setattr(out, name, shapes[name] * level if np.ndim(getattr(base, name)) else level)
        return out

    from scipy.optimize import minimize  # imported here: 0.2 s of import that most calibrations do not need

    start = [np.log(np.clip(terms[n][0], terms[n][1], terms[n][2])) for n in names]
    bounds = [(np.log(terms[n][1]), np.log(terms[n][2])) for n in names]
    result = minimize(lambda t: restricted_likelihood(system, columns, model_of(t)), start, method="Nelder-Mead",
                      bounds=bounds, options={"xatol": 0.03, "fatol": 0.05, "maxfev": 40 * len(names)})
    return model_of(result.x)


def estimate_unmodelled(observations: ObservationTable, residuals: np.ndarray, jacobian: np.ndarray,
                        system: NoiseSystem, noise: SensorNoise, use_rotation_steps: bool) -> tuple[SensorNoise, dict]:
    """Variances of the errors outside the model, by restricted maximum likelihood at a fit, and the tops of
    their search ranges (field -> SI value).

    The terms (an acceleration constant in each static segment, a rate on each static gyro mean, a
    velocity error at each rotation when its step is used) take the share of the misfit that the data
    assign to them, and the relative weight of velocity and gyro residuals follows.  ``residuals`` and
    ``jacobian`` are the fit's, linearised at its solution.
    """
    r = residuals
    velocity = observations.rows_of(ObservationKind.VELOCITY)
    gyro = observations.rows_of(ObservationKind.GYRO_MEAN)
    start_acc = np.sqrt(np.mean(r[velocity] ** 2)) / 100.0  # a slope of the residuals' size per 100 s
    start_rate = np.sqrt(np.mean(r[gyro] ** 2)) if gyro.any() else 1e-9
    low_acc, high_acc = UNMODELLED_ACCELERATION_RANGE
    low_rate, high_rate = UNMODELLED_RATE_RANGE
    terms = {"unmodelled_acceleration": (start_acc, low_acc, max(high_acc, UNMODELLED_HEADROOM * start_acc)),
             "unmodelled_rate": (start_rate, low_rate, max(high_rate, UNMODELLED_HEADROOM * start_rate))}
    if use_rotation_steps:
        terms["unmodelled_step"] = (1e-4, *UNMODELLED_STEP_RANGE)
    tops = {name: high for name, (_, _, high) in terms.items()}
    return estimate_terms(system, np.column_stack([r, jacobian]), noise, terms), tops


def estimate_free_terms(model: SensorNoise, noise_plan: NoisePlan, system: NoiseSystem,
                         columns: np.ndarray) -> SensorNoise:
    """The white-noise terms the raw data did not determine (coarse pulses hide them), by restricted
    maximum likelihood between the floors and the raw data's upper bounds; with the accelerometers'
    white noise also their quantization when the raw data estimated it (a counter's is known: one pulse)."""
    free = [t for terms in noise_plan.free_terms().values() for t in terms]
    bounds = noise_plan.raw.upper_bounds()
    ranges = {"gyro_arw": (GYRO_ARW_FLOOR, max(float(bounds.gyro_arw.max()), GYRO_ARW_FLOOR * 10)),
              "accel_vrw": (ACCEL_VRW_FLOOR, max(float(bounds.accel_vrw.max()), ACCEL_VRW_FLOOR * 10))}
    model = dataclasses.replace(model)
    for t in free:  # no shape across axes is known: one level for the three
        setattr(model, t, np.full(3, float(np.median(getattr(model, t)))))
    terms = {t: (float(np.max(getattr(model, t))), *ranges[t]) for t in free}
    if "accel_vrw" in free and np.max(model.accel_quantization) > 0 and not noise_plan.raw.counter.get("accel"):
        q = float(np.max(model.accel_quantization))
        terms["accel_quantization"] = (q, q / 10.0, q * 10.0)
    return estimate_terms(system, columns, model, terms)


def unmodelled_at_bounds(noise: SensorNoise, tops: dict | None = None, binding_only: bool = False) -> list[str]:
    """Warnings for unmodelled terms that reached the top of their search range (``tops``, field -> SI, from
    :func:`estimate_unmodelled`; default the navigation-grade ranges): the errors outside the model are larger
    than it can represent, and the sigma may not cover them.

    With ``binding_only`` only the terms whose top is the fixed navigation-grade one: a top raised to
    :data:`UNMODELLED_HEADROOM` times the fit's own residuals (a MEMS unit) that is reached says that the data
    cannot bound the term (its residuals then weigh nothing, which the sigma accounts for), not that the errors
    exceed what the model can hold."""
    tops = tops or {}
    out = []
    for name, value, (_, high), unit, scale in (
            ("unmodelled acceleration", noise.unmodelled_acceleration, UNMODELLED_ACCELERATION_RANGE, "m/s^2", 1.0),
            ("unmodelled rate", noise.unmodelled_rate, UNMODELLED_RATE_RANGE, "rad/s", 1.0),
            ("unmodelled step", noise.unmodelled_step, UNMODELLED_STEP_RANGE, "m/s", 1.0)):
        fixed, high = high, tops.get(name.replace(" ", "_"), high)
        if binding_only and high > fixed:
            continue
        if value < 0.9 * high:
            continue
        if high > fixed:  # the top was raised to the residuals' headroom: the data do not bound the term
            out.append(f"the {name} reached the top of its range ({value / scale:.3g} {unit}, {UNMODELLED_HEADROOM:g} "
                       "times the residuals): the data do not bound it, so the residuals it sits on carry no weight "
                       "(the sigma is of what the rest determines)")
        else:
            out.append(f"the {name} reached its bound ({value / scale:.3g} of at most {high:g} {unit}): the errors "
                       "outside the model are beyond what it can represent; this table is not to be trusted")
    return out
