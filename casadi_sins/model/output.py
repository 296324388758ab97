"""The output model (Kang et al. 2013, eq. 1), its exact inverse, and the error update (eqs. 22-25).

Per sample interval ``dt``, with ``dtheta`` the true angular increment and ``dv`` the true
specific-force increment in the body frame::

    dN_g = diag(S_g)^-1 (K_g dtheta + B_g dt)          (eq. 1)
    dN_a = diag(S_a)^-1 (K_a dv     + B_a dt)

Compensation inverts the model exactly (``K^-1``, never ``I - k``: physics pitfall 3).  Both are
written once, as CasADi expressions, so that the simulator, the navigation and the symbolic
estimator share them; on NumPy arrays they are applied as the affine maps they are.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from .registry import (ACCEL_BIAS, ACCEL_MISALIGN, ACCEL_MISALIGN_ENTRIES, ACCEL_SCALE, GROUPS, GYRO_BIAS,
                       GYRO_MISALIGN, GYRO_MISALIGN_ENTRIES, GYRO_SCALE, N_PARAMS, SCALE_MASK, groups_in,
                       regressor_blocks)
from .regressors import boundary_rates, layout, sample_rows, step_rows
from .regressors import size as regressor_size


def sensor_matrices(p):
    """``(K_a, S_a, B_a, K_g, S_g, B_g)`` of a parameter vector (CasADi or NumPy, SI; the 21 first).

    ``S`` and ``B`` are 3-vectors, ``K`` the 3x3 misalignment matrices of eq. 1 (unit diagonal;
    ``K_a`` lower triangular; row = sensor axis).
    """
    if not isinstance(p, (ca.SX, ca.MX, ca.DM)):
        p = ca.DM(np.asarray(p, dtype=float).ravel()[:N_PARAMS])

    def misalignment(entries, offset):
        rows = [[1 if i == j else 0 for j in range(3)] for i in range(3)]
        for n, (i, j) in enumerate(entries):
            rows[i][j] = p[offset + n]
        return ca.vertcat(*[ca.horzcat(*row) for row in rows])

    k_a = misalignment(ACCEL_MISALIGN_ENTRIES, ACCEL_MISALIGN.start)
    k_g = misalignment(GYRO_MISALIGN_ENTRIES, GYRO_MISALIGN.start)
    return k_a, p[ACCEL_SCALE], p[ACCEL_BIAS], k_g, p[GYRO_SCALE], p[GYRO_BIAS]


def output_model_expr(dtheta, dv, p, dt, added=None):
    """Raw pulses ``(dN_g, dN_a)`` from true increments (eq. 1); CasADi expressions.

    ``dtheta``, ``dv`` may be 3 x n matrices of n intervals with ``dt`` a 1 x n row.  ``added`` =
    ``(gyro, accel)``: what the extra groups add to ``K dtheta + B dt`` and ``K dv + B dt`` (their physics,
    :mod:`model.groups`).
    """
    k_a, s_a, b_a, k_g, s_g, b_g = sensor_matrices(p)
    gyro, accel = k_g @ dtheta + b_g @ dt, k_a @ dv + b_a @ dt
    if added is not None:
        gyro, accel = gyro + added[0], accel + added[1]
    return ca.diag(1 / s_g) @ gyro, ca.diag(1 / s_a) @ accel


def compensate_expr(dn_g, dn_a, p, dt, extras=None):
    """Increments ``(dtheta, dv)`` from raw pulses: the exact inverse of eq. 1 (CasADi).

    ``dn_g``, ``dn_a`` may be 3 x n matrices of pulse sums over n intervals with ``dt`` a 1 x n row
    (the model is linear, so summed pulses compensate exactly to summed increments).
    ``extras`` = ``(values, names, regressors)``: the extra parameters' values (CasADi), their names and
    the steps' regressor array (:func:`model.regressors.layout` of their blocks); each extra group's
    correction enters its sensor's increments before ``K^-1`` (:mod:`model.groups`), computed from the
    increments compensated with the 21.
    """
    k_a, s_a, b_a, k_g, s_g, b_g = sensor_matrices(p)
    sensed_g = ca.diag(s_g) @ dn_g - b_g @ dt
    sensed_a = ca.diag(s_a) @ dn_a - b_a @ dt
    dtheta, dv = ca.solve(k_g, sensed_g), ca.solve(k_a, sensed_a)
    if extras is None:
        return dtheta, dv
    c_g, c_a = corrections_expr(*extras, dtheta, dv)
    if c_a is not None:
        dv = ca.solve(k_a, sensed_a + c_a)
    if c_g is not None:
        dtheta = ca.solve(k_g, sensed_g + c_g)
    return dtheta, dv


def corrections_expr(extra_values, names, regressors, dtheta, dv):
    """The extra groups' corrections ``(c_g, c_a)`` (3 x M each, ``None`` when no group acts on a sensor).

    ``extra_values`` are the values (CasADi) of ``names`` (the extra parameters, in order), ``regressors``
    the steps' regressor rows of the blocks the groups read (:mod:`model.regressors`), ``dtheta``, ``dv``
    the steps' increments compensated with the 21.
    """
    values = {name: extra_values[i] for i, name in enumerate(names)}
    rows = {block: regressors[span, :] for block, span in layout(regressor_blocks(names)).items()}
    out = {"gyro": None, "accel": None}
    for key in groups_in(names):
        group = GROUPS[key]
        terms = group.correction({n: values[n] for n in group.names if n in values}, rows, dtheta, dv)
        term = ca.vertcat(*terms)
        out[group.sensor] = term if out[group.sensor] is None else out[group.sensor] + term
    return out["gyro"], out["accel"]


@functools.lru_cache(maxsize=None)
def _affine_function(which: str) -> ca.Function:
    """``(p, dt) -> (M_1, c_1, M_2, c_2)``: eq. 1 or its inverse is affine in its input, ``y = M x + c``."""
    expr = output_model_expr if which == "output" else compensate_expr
    a, b, p, dt = ca.SX.sym("a", 3), ca.SX.sym("b", 3), ca.SX.sym("p", N_PARAMS), ca.SX.sym("dt")
    out_a, out_b = expr(a, b, p, dt)
    at_zero = ca.substitute([out_a, out_b], [a, b], [ca.DM.zeros(3), ca.DM.zeros(3)])
    return ca.Function(f"{which}_affine", [p, dt],
                       [ca.jacobian(out_a, a), at_zero[0], ca.jacobian(out_b, b), at_zero[1]])


def _apply_rows(which: str, a, b, p, dt: float):
    core = np.asarray(p, dtype=float)[:N_PARAMS]  # the extras act through model.groups, not here
    m_a, c_a, m_b, c_b = (np.asarray(x) for x in _affine_function(which)(core, dt))
    a = np.atleast_2d(np.asarray(a, dtype=float))
    b = np.atleast_2d(np.asarray(b, dtype=float))
    return a @ m_a.T + c_a.T, b @ m_b.T + c_b.T


def output_model(dtheta, dv, p, dt: float):
    """Raw pulses from true increments, rows of samples: arrays (N, 3) -> ``(dN_g, dN_a)`` (N, 3)."""
    return _apply_rows("output", dtheta, dv, p, dt)


def compensate(dn_g, dn_a, p, dt: float):
    """Compensated increments from raw pulses, rows of samples: arrays (N, 3) -> ``(dtheta, dv)`` (N, 3).

    Evaluates :func:`compensate_expr` as the affine map it is (its Jacobian and offset, from CasADi)
    and applies that to all samples at once.
    """
    return _apply_rows("compensate", dn_g, dn_a, p, dt)


@functools.lru_cache(maxsize=None)
def _sample_function(names: tuple[str, ...]) -> ca.Function:
    """``(dN_g, dN_a, p, dt, extra values, regressors) -> (dtheta, dv)`` of one sample, every group of ``names``."""
    rows = regressor_size(regressor_blocks(names))
    dn_g, dn_a, p, dt = ca.SX.sym("dn_g", 3), ca.SX.sym("dn_a", 3), ca.SX.sym("p", N_PARAMS), ca.SX.sym("dt")
    extra, regs = ca.SX.sym("extra", len(names) - N_PARAMS), ca.SX.sym("regs", rows)
    dtheta, dv = compensate_expr(dn_g, dn_a, p, dt, (extra, names[N_PARAMS:], regs))
    return ca.Function("compensate_sample", [dn_g, dn_a, p, dt, extra, regs], [dtheta, dv])


def compensate_table(dn_g, dn_a, values, names, dt: float):
    """Compensated increments (N, 3) from raw pulses (N, 3) with a whole table: the 21 (:func:`compensate`)
    and its extra groups sample by sample (their regressors from the samples compensated with the 21,
    :mod:`model.regressors`; the time-offset regressor keeps the Earth rate, a 1e-7 relative error)."""
    names, values = tuple(names), np.asarray(values, dtype=float)
    dtheta, dv = compensate(dn_g, dn_a, values[:N_PARAMS], dt)
    if len(names) == N_PARAMS:
        return dtheta, dv
    blocks, n = regressor_blocks(names), len(dtheta)
    regs = step_rows(sample_rows(dtheta, dv, dt, blocks), boundary_rates(dtheta, dt), np.arange(n),
                     np.arange(1, n + 1), blocks)
    out = _sample_function(names).map(n)(np.asarray(dn_g, float).T, np.asarray(dn_a, float).T, values[:N_PARAMS], dt,
                                         values[N_PARAMS:], regs)
    return np.asarray(out[0]).T, np.asarray(out[1]).T


def compensation_matrices(p) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per sensor ``(M, c)`` with ``increment = M dN + c dt``: ``M = K^-1 diag(S)``, ``c = -K^-1 B``."""
    m_g, c_g, m_a, c_a = (np.asarray(x) for x in _affine_function("compensate")(np.asarray(p, float)[:N_PARAMS], 1.0))
    return {"gyro": (m_g, c_g.ravel()), "accel": (m_a, c_a.ravel())}


def apply_error_estimate(p, errors) -> np.ndarray:
    """Correct parameters with estimated errors (eqs. 22-25).

    ``errors`` is ordered like the 21 names: for biases ``eps``/``Delta`` (true minus estimated, SI),
    for scale factors ``t_ii = S_hat/S - 1``, for misalignments ``t_ij = k - k_hat``.  Returns::

        k_ij <- k_hat_ij + t_ij,   S_i <- S_hat_i / (1 + t_ii),   B <- B_hat + eps
    """
    p = np.asarray(p, dtype=float).copy()
    errors = np.asarray(errors, dtype=float)
    p[~SCALE_MASK] += errors[~SCALE_MASK]
    p[SCALE_MASK] /= 1.0 + errors[SCALE_MASK]
    return p
