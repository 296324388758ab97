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
``x``: the functions return sensitivity matrices with 21 columns.
"""

from __future__ import annotations

import numpy as np

from ..core.rotations import quat_to_dcm, rotation_matrix
from ..data.recording import Recording
from ..model.registry import (ACCEL_BIAS, ACCEL_MISALIGN, ACCEL_MISALIGN_ENTRIES, ACCEL_SCALE, GYRO_BIAS,
                              GYRO_MISALIGN, GYRO_MISALIGN_ENTRIES, GYRO_SCALE, N_PARAMS)
from .alignment import alignment_error
from .navigation import GroupNavigation, compensated_increments


def input_sensitivity(increments: np.ndarray, dt: float, sensor: str) -> np.ndarray:
    """``d(increment error)/dx`` per sample, shape (N, 3, 21), for ``sensor`` ``"gyro"`` or ``"accel"``.

    ``increments`` (N, 3) are the compensated increments (``omega dt`` or ``f dt``).
    """
    n = len(increments)
    g = np.zeros((n, 3, N_PARAMS))
    if sensor == "gyro":
        bias, scale, misalign, entries = GYRO_BIAS, GYRO_SCALE, GYRO_MISALIGN, GYRO_MISALIGN_ENTRIES
    else:
        bias, scale, misalign, entries = ACCEL_BIAS, ACCEL_SCALE, ACCEL_MISALIGN, ACCEL_MISALIGN_ENTRIES
    for i in range(3):
        g[:, i, bias.start + i] = dt
        g[:, i, scale.start + i] = increments[:, i]
    for m, (i, j) in enumerate(entries):
        g[:, i, misalign.start + m] = increments[:, j]
    return g


def alignment_sensitivity(dtheta: np.ndarray, dv: np.ndarray, dt: float) -> np.ndarray:
    """``d(phi_0)/dx`` (3, 21): the attitude error of the coarse alignment (eq. 15), linearised."""
    d_means = np.vstack([input_sensitivity(dv, dt, "accel").mean(axis=0),
                         input_sensitivity(dtheta, dt, "gyro").mean(axis=0)]) / dt  # (6, 21)
    return alignment_error(dv.mean(axis=0) / dt, dtheta.mean(axis=0) / dt, d_means)


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

    c_after = quat_to_dcm(nav.quaternion)
    c_before = np.concatenate([nav.initial_attitude[None], c_after[:-1]])
    c_mid = 0.5 * (c_before + c_after)
    gyro_nav = c_mid @ input_sensitivity(dtheta, dt, "gyro")  # (N, 3, 21)
    accel_nav = c_mid @ input_sensitivity(dv, dt, "accel")

    w_ie = rec.site.earth_rate
    rate = np.linalg.norm(w_ie)
    t = (np.arange(len(dtheta)) + 1) * dt
    earth_turn = rotation_matrix(w_ie, -rate * t)  # R(t_k), (N, 3, 3)
    accumulated = np.cumsum(np.swapaxes(earth_turn, 1, 2) @ gyro_nav, axis=0)
    phi = earth_turn @ (phi0[None] - accumulated)
    phi_mid = 0.5 * (np.concatenate([phi0[None], phi[:-1]]) + phi)
    # f^n dt as the navigation computed it (rotation terms included), not C_{k-1} dv_k, which during a
    # rotation carries a spurious horizontal part of order g w dt / 2
    velocity = np.concatenate([np.zeros((1, 3)), nav.velocity])
    force_dt = np.diff(velocity, axis=0) + np.array([0.0, 0.0, rec.site.g * dt])
    dv_dot = np.cross(force_dt[:, :, None], phi_mid, axis=1) + accel_nav
    return np.cumsum(dv_dot, axis=0)
