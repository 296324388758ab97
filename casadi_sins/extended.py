"""The output model beyond the paper's 21 parameters: terms that need more than one sample.

The extra groups (:data:`parameters.EXTRA_GROUPS`) act on the accelerometers only.  With ``f`` the
specific force at the navigation point (the z accelerometer) and ``w`` the body rate, accelerometer
``i`` senses (extending eq. 1)::

    a_i    = (K_a f(t + tau))_i + e_i . (w_dot x p_i + w x (w x p_i))      lever arm p_i, time offset tau
    dN_a,i = (int (a_i + k2_i a_i^2) dt + B_a,i dt) / S_a,i                 quadratic scale k2

Compensation over a navigation step (a sum of samples) inverts it to first order in the extras::

    dv = K_a^-1 (diag(S_a) dN_a - B_a h + c),    c = -k2 * Q2 - L(p) + tau X

with regressors taken from the samples around the step, compensated with reference parameters
(the extras are small: a ppm change of the reference changes them by a ppm of a micro-g)::

    Q2  = sum a_k^2 dt                              per axis
    X   = sum ((dtheta_k - w_s dt) x dv_k) / dt     (w_nb x f: the turn relative to the Earth, which
                                                      moves f in the body; w_s is the mean rate of the
                                                      last static segment, the Earth rate and bias)
    L_i = (e_i x dw + M[i, :]) . p_i,   dw = w(end) - w(start),  M = sum (w_k w_k^T - |w_k|^2 I) dt

The angular acceleration enters through ``dw``: the rate at a step's ends from the neighbouring
samples, ``w(t_k) = (dtheta_k + dtheta_k+1) / (2 dt)``.  Static blocks stay exact: at rest ``X``,
``dw`` and ``M`` vanish up to the Earth rate and ``Q2`` is a sum over the block's samples.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from . import parameters as P

#: Rows of the regressor array of a step: Q2 (3), X (3), dw (3), M (xx, yy, zz, xy, xz, yz).
Q2, X, DW, M = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 15)
N_REGRESSORS = 15


def sample_regressors(gyro: np.ndarray, accel: np.ndarray, reference: np.ndarray, dt: float,
                      static_rate: np.ndarray | None = None) -> np.ndarray:
    """Per-sample regressors (N, 15) of a recording's samples, and the boundary rates (N + 1, 3).

    Returns ``(per_sample, boundary_rate)``: ``per_sample`` holds Q2, X, 0 (the dw slot) and M of each
    sample; ``boundary_rate[k]`` is the rate at the start of sample ``k`` (``N``: the end).
    ``static_rate`` (N, 3) is the rate each sample's body has at rest (Earth rate and bias), taken out
    of the time-offset regressor.
    """
    dtheta, dv = P.compensate(gyro, accel, reference[: P.N_PARAMS], dt)
    w = dtheta / dt
    out = np.zeros((len(dtheta), N_REGRESSORS))
    out[:, Q2] = dv**2 / dt
    turn = dtheta if static_rate is None else dtheta - static_rate * dt
    out[:, X] = np.cross(turn, dv) / dt
    sq = np.sum(w * w, axis=1)
    out[:, 9] = (w[:, 0] ** 2 - sq) * dt
    out[:, 10] = (w[:, 1] ** 2 - sq) * dt
    out[:, 11] = (w[:, 2] ** 2 - sq) * dt
    out[:, 12] = w[:, 0] * w[:, 1] * dt
    out[:, 13] = w[:, 0] * w[:, 2] * dt
    out[:, 14] = w[:, 1] * w[:, 2] * dt
    padded = np.vstack([w[:1], w, w[-1:]])
    boundary = 0.5 * (padded[:-1] + padded[1:])
    return out, boundary


def static_rates(rec, reference: np.ndarray) -> np.ndarray:
    """(N, 3) the body rate each sample would have at rest (Earth rate and bias, body frame).

    In a static segment: its mean compensated rate.  Between static segments the body turns, and the
    rate at rest turns with it: the previous segment's mean, rotated back by the angle turned since
    (the accumulated increments less the rate at rest: exact for turns about one axis).
    """
    from .frames import rotation_matrices

    dtheta_all, _ = P.compensate(rec.gyro, rec.accel, reference[: P.N_PARAMS], rec.dt)
    out = np.zeros((len(rec.time), 3))
    for group in rec.group_ids:
        span = rec.group_samples(group)
        cursor, rate = span.start, None
        for seg in rec.group_segments(group):
            sl = rec.segment_samples(seg)
            if seg.is_static:
                rate = dtheta_all[sl].mean(axis=0) / rec.dt
                if cursor < sl.start:  # samples between segments before the first static: at rest
                    out[cursor:sl.start] = rate
                out[sl] = rate
                cursor = sl.stop
                continue
            stop = sl.stop
            turned = np.cumsum(dtheta_all[cursor:stop] - rate * rec.dt, axis=0)
            out[cursor:stop] = np.einsum("nji,j->ni", rotation_matrices(turned), rate)
            cursor = stop
        if cursor < span.stop:
            out[cursor:span.stop] = rate
    return out


def step_regressors(per_sample: np.ndarray, boundary_rate: np.ndarray, first: np.ndarray,
                    stop: np.ndarray) -> np.ndarray:
    """Regressors (15, M) of steps covering samples ``first[j]:stop[j]``."""
    cumulative = np.vstack([np.zeros(N_REGRESSORS), np.cumsum(per_sample, axis=0)])
    out = (cumulative[stop] - cumulative[first]).T
    out[DW] = (boundary_rate[stop] - boundary_rate[first]).T
    return out


def correction_expr(extra_values, names, regressors):
    """The correction ``c`` (3 x M) of :func:`compensate_expr`'s accelerometer increments (CasADi).

    ``extra_values`` are the values of the extra ``names`` (SI), ``regressors`` a (15, M) matrix.
    """
    values = dict(zip(names, [extra_values[k] for k in range(len(names))]))
    reg = regressors
    terms = [ca.DM.zeros(1, reg.shape[1]) for _ in range(3)]
    if "accel_quadratic_x" in values:
        for i, axis in enumerate("xyz"):
            terms[i] = terms[i] - values[f"accel_quadratic_{axis}"] * reg[Q2.start + i, :]
    if "accel_time_offset" in values:
        for i in range(3):
            terms[i] = terms[i] + values["accel_time_offset"] * reg[X.start + i, :]
    if any(name.startswith("accel_x_lever") for name in values):
        dw = [reg[DW.start + k, :] for k in range(3)]
        m = {(0, 0): reg[9, :], (1, 1): reg[10, :], (2, 2): reg[11, :], (0, 1): reg[12, :], (0, 2): reg[13, :],
             (1, 2): reg[14, :]}
        for i, axis in enumerate("xy"):
            # e_i x dw, component j, dotted with p; plus M[i, :] . p (components not estimated are 0)
            cross = {0: (0, -dw[2], dw[1]), 1: (dw[2], 0, -dw[0])}[i]
            for j, component in enumerate("xyz"):
                name = f"accel_{axis}_lever_{component}"
                if name in values:
                    terms[i] = terms[i] - values[name] * (cross[j] + m[(min(i, j), max(i, j))])
    return ca.vertcat(*terms)


def sensed_extras(kinematics, t0: np.ndarray, t1: np.ndarray, truth: P.ParameterSet, nodes=6):
    """What the extras add to each accelerometer sample ``[t0, t1]``, for the simulator (exact physics).

    ``kinematics(t)`` gives ``(C_b^n, w_b, w_dot_b, f_b)`` at times ``t`` (any shape). Returns
    ``(dv_f, dv_lever, q2)``: the time-shifted specific-force increment ``int f_b(t + tau) dt``, the
    lever-arm increment ``int l dt`` and ``int a^2 dt`` (per axis, (N, 3) each).
    """
    x, w = np.polynomial.legendre.leggauss(nodes)
    tau = truth["accel_time_offset"] if "accel_time_offset" in truth.names else 0.0
    points = t0[:, None] + (t1 - t0)[:, None] * (1.0 + x[None, :]) / 2.0 + tau
    weights = (t1 - t0)[:, None] * w[None, :] / 2.0
    _, rate, rate_dot, force = kinematics(points)
    lever = np.zeros_like(force)
    if any(name.startswith("accel_x_lever") for name in truth.names):
        for i, axis in enumerate("xy"):
            p = np.array([truth[f"accel_{axis}_lever_{c}"] if f"accel_{axis}_lever_{c}" in truth.names else 0.0
                          for c in "xyz"])
            arm = np.cross(rate_dot, p) + np.cross(rate, np.cross(rate, p))
            lever[..., i] = arm[..., i]
    sensed = force + lever
    dv_f = np.einsum("nj,njk->nk", weights, force)
    dv_lever = np.einsum("nj,njk->nk", weights, lever)
    q2 = np.einsum("nj,njk->nk", weights, sensed**2)
    return dv_f, dv_lever, q2
