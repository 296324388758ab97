"""Linear error model of static navigation (Kang et al. 2013, eqs. 5-21), along a navigated trajectory.

The error state of the parameters, ordered like :data:`parameters.NAMES`::

    x = (Delta, t_a_ii, t_a_ij, eps, t_g_ii, t_g_ij)

with ``Delta = B_a - B_a_hat``, ``t_ii = S_hat_i/S_i - 1``, ``t_ij = k_ij - k_hat_ij``,
``eps = B_g - B_g_hat``.  The compensated outputs then err by (eqs. 5-12)::

    d_omega = T_g omega + eps,     d_f = T_a f + Delta

and the attitude error ``phi`` (``C_hat = (I - [phi x]) C``) and velocity error
obey, on a static base in ENU (eqs. 13-21)::

    phi'  = -w_ie^n x phi - C_b^n d_omega
    dv'   =  f^n x phi    + C_b^n d_f

The alignment errors (eq. 15) follow from linearising the one alignment
function (:func:`strapdown.alignment_expr`).  Everything here is linear in
``x``: the functions return sensitivity matrices with 21 columns.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from . import frames
from . import parameters as P
from .recording import Recording
from .strapdown import GroupNavigation, alignment_expr, compensated_increments, quat_to_dcm


def input_sensitivity(increments: np.ndarray, dt: float, sensor: str) -> np.ndarray:
    """``d(increment error)/dx`` per sample, shape (N, 3, 21), for ``sensor`` ``"gyro"`` or ``"accel"``.

    ``increments`` (N, 3) are the compensated increments (``omega dt`` or ``f dt``).
    """
    n = len(increments)
    g = np.zeros((n, 3, P.N_PARAMS))
    if sensor == "gyro":
        bias, scale, misalign, entries = P.GYRO_BIAS, P.GYRO_SCALE, P.GYRO_MISALIGN, P.GYRO_MISALIGN_ENTRIES
    else:
        bias, scale, misalign, entries = P.ACCEL_BIAS, P.ACCEL_SCALE, P.ACCEL_MISALIGN, P.ACCEL_MISALIGN_ENTRIES
    for i in range(3):
        g[:, i, bias.start + i] = dt
        g[:, i, scale.start + i] = increments[:, i]
    for m, (i, j) in enumerate(entries):
        g[:, i, misalign.start + m] = increments[:, j]
    return g


@functools.lru_cache(maxsize=None)
def _alignment_jacobian() -> ca.Function:
    f, w = ca.SX.sym("f", 3), ca.SX.sym("w", 3)
    dcm = alignment_expr(f, w)
    return ca.Function("alignment_jacobian", [f, w], [dcm, ca.jacobian(ca.vec(dcm), ca.vertcat(f, w))])


def alignment_sensitivity(dtheta: np.ndarray, dv: np.ndarray, dt: float) -> np.ndarray:
    """``d(phi_0)/dx`` (3, 21): the attitude error of the coarse alignment (eq. 15), linearised."""
    f_mean, w_mean = dv.mean(axis=0) / dt, dtheta.mean(axis=0) / dt
    dcm, jac = (np.asarray(m) for m in _alignment_jacobian()(f_mean, w_mean))
    d_means = np.vstack([input_sensitivity(dv, dt, "accel").mean(axis=0),
                         input_sensitivity(dtheta, dt, "gyro").mean(axis=0)]) / dt  # (6, 21)
    d_dcm = (jac @ d_means).reshape(3, 3, P.N_PARAMS, order="F")  # vec() is column-major
    phi_cross = -np.einsum("ijp,kj->ikp", d_dcm, dcm)  # [phi x] = -dC C^T
    return np.stack([phi_cross[2, 1], phi_cross[0, 2], phi_cross[1, 0]])


@functools.lru_cache(maxsize=None)
def _quat_to_dcm_function() -> ca.Function:
    q = ca.SX.sym("q", 4)
    return ca.Function("quat_to_dcm", [q], [ca.vec(quat_to_dcm(q))])


def quat_to_dcm_batch(q: np.ndarray) -> np.ndarray:
    """:func:`strapdown.quat_to_dcm` evaluated for an array of quaternions (N, 4) -> (N, 3, 3)."""
    flat = np.asarray(_quat_to_dcm_function().map(len(q))(np.asarray(q, dtype=float).T))
    return flat.T.reshape(len(q), 3, 3).transpose(0, 2, 1)  # vec() is column-major


def velocity_sensitivity(rec: Recording, nav: GroupNavigation, params: np.ndarray) -> np.ndarray:
    """``d(velocity error)/dx`` after each sample of a navigated group, shape (N, 3, 21).

    Propagates the error model above along the navigated attitude.  The
    ``-w_ie x phi`` term is solved exactly: with ``R(t) = exp(-[w_ie x] t)``,
    ``phi_k = R(t_k) (phi_0 - sum_j R(t_j)^T C_j d_theta_j)``.
    """
    dt = rec.dt
    dtheta, dv = compensated_increments(rec, params, nav.samples)
    first = rec.segment_samples(rec.group_segments(nav.group)[0])
    local = slice(first.start - nav.samples.start, first.stop - nav.samples.start)
    phi0 = alignment_sensitivity(dtheta[local], dv[local], dt)

    c_after = quat_to_dcm_batch(nav.quaternion)
    c_before = np.concatenate([nav.initial_attitude[None], c_after[:-1]])
    c_mid = 0.5 * (c_before + c_after)
    gyro_nav = c_mid @ input_sensitivity(dtheta, dt, "gyro")  # (N, 3, 21)
    accel_nav = c_mid @ input_sensitivity(dv, dt, "accel")

    w_ie = rec.site.earth_rate
    rate = np.linalg.norm(w_ie)
    t = (np.arange(len(dtheta)) + 1) * dt
    earth_turn = frames.rotation_matrix(w_ie, -rate * t)  # R(t_k), (N, 3, 3)
    accumulated = np.cumsum(np.swapaxes(earth_turn, 1, 2) @ gyro_nav, axis=0)
    phi = earth_turn @ (phi0[None] - accumulated)
    phi_mid = 0.5 * (np.concatenate([phi0[None], phi[:-1]]) + phi)
    # f^n dt as the navigation computed it (rotation terms included), not C_{k-1} dv_k, which during a
    # rotation carries a spurious horizontal part of order g w dt / 2
    velocity = np.concatenate([np.zeros((1, 3)), nav.velocity])
    force_dt = np.diff(velocity, axis=0) + np.array([0.0, 0.0, rec.site.g * dt])
    dv_dot = np.cross(force_dt[:, :, None], phi_mid, axis=1) + accel_nav
    return np.cumsum(dv_dot, axis=0)
