"""The physics of the output-model terms beyond the paper's 21 (accelerometers only).

With ``f`` the specific force at the navigation point (the z accelerometer) and ``w`` the body
rate, accelerometer ``i`` senses (extending eq. 1)::

    a_i    = (K_a f(t + tau))_i + e_i . (w_dot x p_i + w x (w x p_i))      lever arm p_i, time offset tau
    dN_a,i = (int (a_i + k2_i a_i^2) dt + B_a,i dt) / S_a,i                 quadratic scale k2

Compensation over a navigation step (a sum of samples) inverts it to first order in the extras::

    dv = K_a^-1 (diag(S_a) dN_a - B_a h + c),    c = -k2 * Q2 - L(p) + tau X

with regressors of each step (:mod:`calibrate.nlp.regressors`), rows of a (15, M) array::

    Q2  = sum a_k^2 dt                              per axis
    X   = sum ((dtheta_k - w_s dt) x dv_k) / dt     the turn relative to the Earth moving f in the body
    dw  = w(end) - w(start)                         the rate change over the step
    M   = sum (w_k w_k^T - |w_k|^2 I) dt            centripetal; L_i = (e_i x dw + M[i, :]) . p_i

Each extra group's correction term is one function here, named by its registry entry
(:data:`model.registry.GROUPS`); the simulator's exact physics of all of them is
:func:`sensed_extras`.
"""

from __future__ import annotations

import numpy as np

#: Rows of the regressor array of a step: Q2 (3), X (3), dw (3), M (xx, yy, zz, xy, xz, yz).
Q2, X, DW, M = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 15)
N_REGRESSORS = 15
_M_ROW = {(0, 0): 9, (1, 1): 10, (2, 2): 11, (0, 1): 12, (0, 2): 13, (1, 2): 14}


def quadratic_correction(values: dict, regressors) -> list:
    """``-k2_i Q2_i`` per axis (``values`` maps names to values or CasADi symbols)."""
    return [-values[f"accel_quadratic_{axis}"] * regressors[Q2.start + i, :] for i, axis in enumerate("xyz")]


def timing_correction(values: dict, regressors) -> list:
    """``tau X_i`` per axis."""
    return [values["accel_time_offset"] * regressors[X.start + i, :] for i in range(3)]


def lever_correction(values: dict, regressors) -> list:
    """``-L_i(p_i)`` for the x and y accelerometers, from whichever lever components ``values`` holds."""
    dw = [regressors[DW.start + k, :] for k in range(3)]
    rows = [0 * regressors[0, :] for _ in range(3)]
    for i, axis in enumerate("xy"):
        cross = {0: (0, -dw[2], dw[1]), 1: (dw[2], 0, -dw[0])}[i]  # e_i x dw
        for j, component in enumerate("xyz"):
            name = f"accel_{axis}_lever_{component}"
            if name in values:
                rows[i] = rows[i] - values[name] * (cross[j] + regressors[_M_ROW[(min(i, j), max(i, j))], :])
    return rows


def lever_positions(values: dict) -> dict[str, np.ndarray]:
    """The x and y accelerometers' positions (m) from the lever-arm values present (others 0)."""
    return {axis: np.array([float(values.get(f"accel_{axis}_lever_{c}", 0.0)) for c in "xyz"]) for axis in "xy"}


def sensed_extras(kinematics, t0: np.ndarray, t1: np.ndarray, values: dict, nodes: int = 6):
    """What the extras add to each accelerometer sample ``[t0, t1]``, for the simulator (exact physics).

    ``kinematics(t)`` gives ``(C_b^n, w_b, w_dot_b, f_b)`` at times ``t`` (any shape); ``values`` maps the
    extra parameters present to their true values.  Returns ``(dv_f, dv_lever, q2)``: the time-shifted
    specific-force increment ``int f_b(t + tau) dt``, the lever-arm increment ``int l dt`` and
    ``int a^2 dt`` (per axis, (N, 3) each), by Gauss-Legendre quadrature.
    """
    x, w = np.polynomial.legendre.leggauss(nodes)
    tau = float(values.get("accel_time_offset", 0.0))
    points = t0[:, None] + (t1 - t0)[:, None] * (1.0 + x[None, :]) / 2.0 + tau
    weights = (t1 - t0)[:, None] * w[None, :] / 2.0
    _, rate, rate_dot, force = kinematics(points)
    lever = np.zeros_like(force)
    for i, (axis, p) in enumerate(lever_positions(values).items()):
        if np.any(p):
            arm = np.cross(rate_dot, p) + np.cross(rate, np.cross(rate, p))
            lever[..., i] = arm[..., i]
    sensed = force + lever
    dv_f = np.einsum("nj,njk->nk", weights, force)
    dv_lever = np.einsum("nj,njk->nk", weights, lever)
    q2 = np.einsum("nj,njk->nk", weights, sensed**2)
    return dv_f, dv_lever, q2


def psins_fields(values: dict) -> dict[str, np.ndarray]:
    """The PSINS ``clbt`` fields of the extra terms: ``Ka2 = -k2``; ``rx, ry`` are compensation values,
    minus the accelerometers' positions; ``tGA`` the time offset."""
    positions = lever_positions(values)
    return {"Ka2": np.array([0.0 - float(values.get(f"accel_quadratic_{a}", 0.0)) for a in "xyz"]),
            "rx": 0.0 - positions["x"], "ry": 0.0 - positions["y"],
            "tGA": float(values.get("accel_time_offset", 0.0))}
