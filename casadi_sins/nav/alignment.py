"""The coarse analytic alignment (Kang et al. 2013, eq. 14) and its linearisation (eq. 15).

Tilt comes from the accelerometers alone (up = f/|f|) and heading from the gyros (east = w x f):
gyro errors do not leak into the tilt (physics pitfall 6).  The formula is
:func:`core.rotations.triad`; here it is a CasADi ``Function`` of the mean specific force and rate,
and its Jacobian gives the alignment's attitude error for any error of those means.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from ..core.rotations import triad


def alignment_expr(mean_specific_force, mean_rate):
    """``C_b^n`` (ENU) from mean body specific force and rate (eq. 14), CasADi."""
    return triad(mean_specific_force, mean_rate)


@functools.lru_cache(maxsize=None)
def alignment_function() -> ca.Function:
    """``(f[3], w[3]) -> C_bn``: eq. 14 as a CasADi ``Function``."""
    f, w = ca.SX.sym("f", 3), ca.SX.sym("w", 3)
    return ca.Function("alignment", [f, w], [alignment_expr(f, w)], ["f", "w"], ["C_bn"])


@functools.lru_cache(maxsize=None)
def _alignment_jacobian() -> ca.Function:
    f, w = ca.SX.sym("f", 3), ca.SX.sym("w", 3)
    dcm = alignment_expr(f, w)
    return ca.Function("alignment_jacobian", [f, w], [dcm, ca.jacobian(ca.vec(dcm), ca.vertcat(f, w))])


def align(dtheta, dv, dt: float) -> np.ndarray:
    """Attitude ``C_b^n`` from compensated static increments (rows of samples)."""
    f = np.asarray(dv).mean(axis=0) / dt
    w = np.asarray(dtheta).mean(axis=0) / dt
    return np.asarray(alignment_function()(f, w))


def alignment_error(mean_force, mean_rate, d_means) -> np.ndarray:
    """Attitude error ``phi`` (``C_hat = (I - [phi x]) C``) of eq. 14 for errors of its inputs (eq. 15).

    Parameters
    ----------
    mean_force, mean_rate : (3,) ndarray
        The means the alignment was computed from (body, SI).
    d_means : (6, K) ndarray
        Errors of the mean force (rows 0-2) and rate (rows 3-5), K columns (e.g. per parameter, or
        per random draw).

    Returns
    -------
    (3, K) ndarray
    """
    dcm, jac = (np.asarray(m) for m in _alignment_jacobian()(mean_force, mean_rate))
    k = d_means.shape[1]
    d_dcm = (jac @ d_means).reshape(3, 3, k, order="F")  # vec() is column-major
    phi_cross = -np.einsum("ijp,kj->ikp", d_dcm, dcm)  # [phi x] = -dC C^T
    return np.stack([phi_cross[2, 1], phi_cross[0, 2], phi_cross[1, 0]])
