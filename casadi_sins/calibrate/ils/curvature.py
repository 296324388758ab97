"""Second order in the ILS's covariance: where its loose combinations reach the tight ones.

The ILS aligns each group on its first static position (eq. 14), so a schedule of few groups leaves some
combinations of the 21 barely determined (a single group of 300 s: thousands of ppm) beside others
determined to a tenth of an arcsec.  At convergence ``A^T W b(p) = 0`` with, for the errors ``e`` of the
values, ``b = -A e + q(e) + n``: the curvature ``q(e) = H[e, e] / 2`` of the equations, of the size of the
loose errors squared, enters the estimate as ``G q(e)`` (``G`` the solve's generalised least squares) and
sits in the tight combinations.  The linear covariance ``C`` misses it; with ``e ~ N(0, C)`` along the loose
directions ``u_k`` (``e = sum z_k u_k``) the second moment it adds is exact for a quadratic ``q``::

    E[q] = 1/2 sum_k h_kk,   E[q q^T] = E[q] E[q]^T + 1/2 sum_kl h_kl h_kl^T,   h_kl = H[u_k, u_l]

with ``h_kl`` from second differences of the equations' right-hand side (the navigation repeated at the
values moved by ``+/- (u_k + u_l)``, :func:`second_difference`).  On the paper's schedule the loose errors
are below a ppm and the term is below 1e-9 of any variance: it is computed only when the loose
combinations' squared size reaches :data:`GATE` of the tightest one's (in dimensionless units: scale
factors and misalignments as they are, accelerometer biases over g, gyro biases times the longest group).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ...model.output import apply_error_estimate
from ...model.registry import NAMES
from .uncertainty import gls_operator

#: Second order is computed when (largest dimensionless sigma)^2 exceeds this fraction of the smallest.
GATE = 1e-3
#: At most this many loose directions (the loose directions of a one-group schedule are a handful).
MAX_DIRECTIONS = 5


def dimensionless_of(rec) -> np.ndarray:
    """:func:`dimensionless` for a recording: its gravity and its longest group."""
    longest = max((rec.group_samples(g).stop - rec.group_samples(g).start) * rec.dt for g in rec.group_ids)
    return dimensionless(rec.site.g, longest)


def dimensionless(g: float, longest_group_s: float) -> np.ndarray:
    """Factors taking the SI error terms (scale factors relative) to dimensionless sizes."""
    out = np.ones(len(NAMES))
    for i, name in enumerate(NAMES):
        if name.startswith("accel_bias"):
            out[i] = 1.0 / g
        elif name.startswith("gyro_bias"):
            out[i] = longest_group_s
    return out


def loose_directions(covariance: np.ndarray, factors: np.ndarray) -> np.ndarray:
    """The directions (columns, SI error terms, each one sigma long and ``C``-orthonormal) whose squared
    dimensionless size reaches :data:`GATE` of the tightest combination's sigma; none when there is none."""
    scaled = covariance * np.outer(factors, factors)
    w, v = np.linalg.eigh(0.5 * (scaled + scaled.T))
    tightest = np.sqrt(max(float(w.min()), 0.0))
    order = np.argsort(w)[::-1][:MAX_DIRECTIONS]
    keep = [k for k in order if w[k] > GATE * tightest]
    return (v[:, keep] * np.sqrt(w[keep])) / factors[:, None]


def second_difference(rhs: Callable[[np.ndarray], np.ndarray], params: np.ndarray, b0: np.ndarray,
                      step: np.ndarray) -> np.ndarray:
    """``H[step, step]``: ``b(p + step) + b(p - step) - 2 b(p)`` with the values moved by the error terms
    ``step`` (eqs. 22-25)."""
    return rhs(apply_error_estimate(params, step)) + rhs(apply_error_estimate(params, -step)) - 2.0 * b0


def with_curvature(rhs: Callable[[np.ndarray], np.ndarray], params: np.ndarray, b0: np.ndarray, a: np.ndarray,
                   weights: np.ndarray, covariance: np.ndarray, factors: np.ndarray) -> tuple[np.ndarray, float]:
    """``covariance`` (SI error terms) with the second order added where the gate opens, and the largest share
    of a variance it makes (0 when closed).  ``rhs(p)`` gives the equations' right-hand side at the values
    ``p``; ``b0`` is it at ``params``, where ``a`` was linearised; ``weights`` those of the solve."""
    directions = loose_directions(covariance, factors)
    k = directions.shape[1]
    if k == 0:
        return covariance, 0.0
    plus = [rhs(apply_error_estimate(params, directions[:, i])) for i in range(k)]
    minus = [rhs(apply_error_estimate(params, -directions[:, i])) for i in range(k)]
    own = [p + m - 2.0 * b0 for p, m in zip(plus, minus)]
    # moving the values by +u moves their errors by -u: the secant along u is -(b(+u) - b(-u)) / 2
    secant = -0.5 * np.column_stack([p - m for p, m in zip(plus, minus)])
    h = {(i, i): own[i] for i in range(k)}
    for i in range(k):
        for j in range(i + 1, k):
            both = second_difference(rhs, params, b0, directions[:, i] + directions[:, j])
            h[i, j] = 0.5 * (both - own[i] - own[j])
    gls = gls_operator(a, weights)
    mean = 0.5 * sum(own)
    moment = np.outer(mean, mean)
    for (i, j), value in h.items():
        moment += (0.5 if i == j else 1.0) * np.outer(value, value)  # h_ij and h_ji alike
    # the design's error along the loose directions, (J - A) e = D U^T C^-1 e, turns the estimate into
    # e = -(I + G D U^T C^-1)^-1 G (n + q)
    mismatch = gls @ (secant - a @ directions) @ np.linalg.solve(covariance, directions).T
    response = np.linalg.inv(np.eye(len(covariance)) + mismatch)
    inner = covariance + gls @ moment @ gls.T
    total = response @ inner @ response.T
    total = 0.5 * (total + total.T)
    return total, float(np.max(1.0 - np.diag(covariance) / np.diag(total)))
