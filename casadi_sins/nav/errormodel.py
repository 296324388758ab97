"""Linear error model of static navigation (Kang et al. 2013, eqs. 5-21), along a navigated trajectory.

The error state of the parameters, ordered like :data:`model.registry.NAMES`::

    x = (Delta, t_a_ii, t_a_ij, eps, t_g_ii, t_g_ij)

with ``Delta = B_a - B_a_hat``, ``t_ii = S_hat_i/S_i - 1``, ``t_ij = k_ij - k_hat_ij``,
``eps = B_g - B_g_hat``.  The compensated outputs then err by (eqs. 5-12)::

    d_omega = T_g omega + eps,     d_f = T_a f + Delta

and the attitude error ``phi`` (``C_hat = (I - [phi x]) C``) and velocity error
obey, on a static base in ENU (eqs. 13-21)::

    phi'  = -w_ie^n x phi - C_b^n d_omega
    dv'   =  f^n x phi    + C_b^n d_f

The alignment errors (eq. 15) follow from linearising the one alignment
function (:mod:`nav.alignment`).  Everything here is linear in
``x``: the functions return sensitivity matrices with 21 columns.  Along a navigated group the model
is propagated sample by sample by one CasADi step (:func:`sensitivity_step_function`), compiled
(:mod:`core.compiled`)::

    phi_k = R phi_(k-1) - C_k G_g(dtheta_k),    R = exp(-[w_ie x] dt)   (exact for -w_ie x phi)
    dv_k  = dv_(k-1) + f^n_k dt x (phi_(k-1) + phi_k) / 2 + C_k G_a(dv_k)

with ``C_k`` the attitude in the middle of the sample and ``G`` the increment errors' sensitivities
(:func:`input_sensitivity`).
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from ..core.compiled import StepChain
from ..core.rotations import quat_to_dcm, rotation_matrix
from ..data.recording import Recording
from ..model.registry import (ACCEL_BIAS, ACCEL_MISALIGN, ACCEL_MISALIGN_ENTRIES, ACCEL_SCALE, GYRO_BIAS,
                              GYRO_MISALIGN, GYRO_MISALIGN_ENTRIES, GYRO_SCALE, N_PARAMS)
from .alignment import alignment_error
from .navigation import GroupNavigation, compensated_increments


def _error_columns(sensor: str) -> list[tuple[int, int, int]]:
    """``(column, axis i, input component j or -1)`` of a sensor's error terms: the increment error of axis
    ``i`` from the term of ``column`` is ``dt`` (``j = -1``, a bias) or the increment's component ``j``."""
    if sensor == "gyro":
        bias, scale, misalign, entries = GYRO_BIAS, GYRO_SCALE, GYRO_MISALIGN, GYRO_MISALIGN_ENTRIES
    else:
        bias, scale, misalign, entries = ACCEL_BIAS, ACCEL_SCALE, ACCEL_MISALIGN, ACCEL_MISALIGN_ENTRIES
    columns = [(bias.start + i, i, -1) for i in range(3)] + [(scale.start + i, i, i) for i in range(3)]
    return columns + [(misalign.start + m, i, j) for m, (i, j) in enumerate(entries)]


def input_sensitivity(increments, dt, sensor: str):
    """``d(increment error)/dx`` per sample, shape (N, 3, 21), for ``sensor`` ``"gyro"`` or ``"accel"``.

    ``increments`` (N, 3) are the compensated increments (``omega dt`` or ``f dt``).  With a CasADi
    3-vector of increments the result is the (3, 21) CasADi matrix of that one sample.
    """
    if isinstance(increments, (ca.SX, ca.MX)):
        g = ca.SX(3, N_PARAMS) if isinstance(increments, ca.SX) else ca.MX(3, N_PARAMS)
        for column, i, j in _error_columns(sensor):
            g[i, column] = dt if j < 0 else increments[j]
        return g
    g = np.zeros((len(increments), 3, N_PARAMS))
    for column, i, j in _error_columns(sensor):
        g[:, i, column] = dt if j < 0 else increments[:, j]
    return g


def alignment_sensitivity(dtheta: np.ndarray, dv: np.ndarray, dt: float) -> np.ndarray:
    """``d(phi_0)/dx`` (3, 21): the attitude error of the coarse alignment (eq. 15), linearised."""
    d_means = np.vstack([input_sensitivity(dv, dt, "accel").mean(axis=0),
                         input_sensitivity(dtheta, dt, "gyro").mean(axis=0)]) / dt  # (6, 21)
    return alignment_error(dv.mean(axis=0) / dt, dtheta.mean(axis=0) / dt, d_means)


@functools.lru_cache(maxsize=None)
def sensitivity_step_function() -> ca.Function:
    """One sample of the error model (module docstring) with its 21 sensitivities, for a compiled chain::

        state = [phi (3 x 21), dv (3 x 21)],  const = [R (9, column-major), dt]
        data  = [C_k (9, column-major), dtheta (3), dv (3), f^n dt (3)]  ->  (state next, const, dv next)
    """
    state, const, data = ca.SX.sym("s", 3, 2 * N_PARAMS), ca.SX.sym("const", 10), ca.SX.sym("data", 18)
    phi, dvs = state[:, :N_PARAMS], state[:, N_PARAMS:]
    r, dt = ca.reshape(const[:9], 3, 3), const[9]
    c = ca.reshape(data[:9], 3, 3)
    force = data[15:18]
    phi_next = r @ phi - c @ input_sensitivity(data[9:12], dt, "gyro")
    mid = 0.5 * (phi + phi_next)
    cross = ca.vertcat(force[1] * mid[2, :] - force[2] * mid[1, :], force[2] * mid[0, :] - force[0] * mid[2, :],
                       force[0] * mid[1, :] - force[1] * mid[0, :])
    dv_next = dvs + cross + c @ input_sensitivity(data[12:15], dt, "accel")
    return ca.Function("sensitivity_step", [state, const, data], [ca.horzcat(phi_next, dv_next), const, dv_next])


@functools.lru_cache(maxsize=None)
def sensitivity_chain() -> StepChain:
    """:func:`sensitivity_step_function` compiled, as a chain over the samples of a group."""
    return StepChain("sensitivity", "error model step", sensitivity_step_function)


def error_model_inputs(rec: Recording, nav: GroupNavigation, params: np.ndarray):
    """What the error model runs on along a navigated group: the compensated increments ``dtheta``, ``dv``
    (N, 3), the alignment's attitude error ``phi0`` (3, 21, eq. 15), the attitude at the middle of each
    sample ``c_mid`` (N, 3, 3) and the navigation's ``f^n dt`` (N, 3)."""
    dtheta, dv = compensated_increments(rec, params, nav.samples)
    first = rec.segment_samples(rec.group_segments(nav.group)[0])
    local = slice(first.start - nav.samples.start, first.stop - nav.samples.start)
    phi0 = alignment_sensitivity(dtheta[local], dv[local], rec.dt)
    c_after = quat_to_dcm(nav.quaternion)
    c_mid = 0.5 * (np.concatenate([nav.initial_attitude[None], c_after[:-1]]) + c_after)
    velocity = np.concatenate([np.zeros((1, 3)), nav.velocity])
    force_dt = np.diff(velocity, axis=0) + np.array([0.0, 0.0, rec.site.g * rec.dt])
    return dtheta, dv, phi0, c_mid, force_dt


def velocity_sensitivity(rec: Recording, nav: GroupNavigation, params: np.ndarray) -> np.ndarray:
    """``d(velocity error)/dx`` after each sample of a navigated group, shape (N, 3, 21).

    Propagates the error model (module docstring) along the navigated attitude from the alignment's
    error (eq. 15).  ``f^n dt`` is the navigation's own velocity change less gravity (rotation terms
    included), not ``C_(k-1) dv_k``, which during a rotation carries a spurious horizontal part of
    order ``g w dt / 2``.
    """
    dt = rec.dt
    dtheta, dv, phi0, c_mid, force_dt = error_model_inputs(rec, nav, params)
    w_ie = rec.site.earth_rate
    earth_turn = rotation_matrix(w_ie, -np.linalg.norm(w_ie) * dt)
    n = len(dtheta)
    data = np.empty((n, 18))
    data[:, :9] = np.swapaxes(c_mid, 1, 2).reshape(n, 9)  # column-major C per row
    data[:, 9:12], data[:, 12:15], data[:, 15:18] = dtheta, dv, force_dt
    state0 = np.hstack([phi0, np.zeros((3, N_PARAMS))])
    out, _ = sensitivity_chain()(state0, np.concatenate([earth_turn.ravel(order="F"), [dt]]), data)
    return out.reshape(n, N_PARAMS, 3).transpose(0, 2, 1)
