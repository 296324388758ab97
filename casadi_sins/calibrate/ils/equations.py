"""The paper's equations (Kang et al. 2013, section 1): polynomial coefficients of the static velocity.

In the static segment after each rotation, the north and east velocity errors are fitted with
``a + b tau + c tau^2`` and the up velocity error with ``a + b tau`` (``tau`` from the start of the
segment); the linear and quadratic coefficients are the equations, 5 per rotation (eqs. 16-21), 45
for the paper's 9 rotations.  The same fits applied to the sensitivities of the velocity error to
the 21 error terms (:mod:`nav.errormodel`) give the design matrix.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ...data.recording import Recording
from ...model.registry import N_PARAMS, NAMES, NATURAL_SCALE
from ...nav.errormodel import velocity_sensitivity
from ...nav.navigation import navigate_group
from ..result import CalibrationError


def coefficient_operator(tau: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows mapping a velocity series at times ``tau`` (s since the segment began) to its polynomial
    slope/curvature, and their covariance under a unit random walk.

    Returns ``(rows, cov)``: ``rows`` (degree, n) gives (b, c) of ``a + b tau + c tau^2``
    (SI: m/s^2, m/s^3); ``cov`` is their covariance for a unit-intensity random walk (variance ``tau``
    m^2/s^2 at ``tau`` seconds).
    """
    tau = np.asarray(tau, dtype=float)
    scale = tau[-1]
    vander = np.vander(tau / scale, degree + 1, increasing=True)
    pinv = np.linalg.pinv(vander)[1:] / scale ** np.arange(1, degree + 1)[:, None]
    # cov = pinv Sigma pinv^T with Sigma_ij = min(tau_i, tau_j), in O(n):
    # (Sigma p)_i = sum_{j<i} tau_j p_j + tau_i sum_{j>=i} p_j
    head = np.cumsum(tau * pinv, axis=1) - tau * pinv
    tail = np.cumsum(pinv[:, ::-1], axis=1)[:, ::-1]
    sigma_p = head + tau * tail
    cov = pinv @ sigma_p.T
    return pinv, cov


@functools.lru_cache(maxsize=256)
def _sample_operator(n: int, dt: float, degree: int) -> np.ndarray:
    """:func:`coefficient_operator` of ``n`` samples ``dt`` apart (the same in every iteration; read-only)."""
    rows, _ = coefficient_operator((np.arange(n) + 1) * dt, degree)
    rows.flags.writeable = False
    return rows


@dataclasses.dataclass(frozen=True)
class Equation:
    """What one equation is: the fitted coefficient of one velocity axis in one static segment."""

    group: int
    segment: int  # segment number
    axis: int  # 0 E, 1 N, 2 U
    order: int  # 1 slope, 2 curvature

    @property
    def label(self) -> str:
        """``"segment 5 v_N curvature"``."""
        return f"segment {self.segment} v_{'ENU'[self.axis]} {['slope', 'curvature'][self.order - 1]}"


def build_equations(rec: Recording, params: np.ndarray, north_quadratic: bool = True,
                    alignment_up: bool = True, design: bool = True):
    """The paper's equations for the current parameters: ``(A, b, equations, navigations)``.

    ``alignment_up`` adds the slope of the up velocity in each group's first (alignment) static
    segment: the alignment takes only the tilt from it, and without it a schedule whose other
    positions never turn an accelerometer up (the paper's y axis) separates its bias and scale
    factor poorly.

    ``A`` (m, 21) maps the error terms (SI, ordered like :data:`model.registry.NAMES`) to the fitted
    coefficients, ``b`` (m,) are the coefficients of the navigated velocity (SI).  Without ``design`` the
    sensitivities are not propagated and ``A`` is ``None``.
    """
    rows, rhs, equations, navs = [], [], [], []
    for group in rec.group_ids:
        nav = navigate_group(rec, group, params)
        navs.append(nav)
        sens = velocity_sensitivity(rec, nav, params) if design else None
        for seg, axes in equation_segments(rec, group, alignment_up):
            sl = rec.segment_samples(seg)
            local = slice(sl.start - nav.samples.start, sl.stop - nav.samples.start)
            n = local.stop - local.start
            before = local.start - 1
            for axis in axes:
                ops = _sample_operator(n, rec.dt, 1 if axis == 2 else 2)
                if axis == 1 and not north_quadratic:
                    ops = ops[:1]
                velocity = nav.velocity[local, axis] - (nav.velocity[before, axis] if before >= 0 else 0.0)
                if design:
                    rows.append(ops @ (sens[local, axis, :] - (sens[before, axis, :] if before >= 0 else 0.0)))
                rhs.append(ops @ velocity)
                equations += [Equation(group, seg.number, axis, k + 1) for k in range(len(ops))]
    return (np.vstack(rows) if design else None), np.concatenate(rhs), equations, navs


def equation_segments(rec: Recording, group: int, alignment_up: bool):
    """``(segment, axes)`` of a group's equations: the static segments after each rotation (E, N, U),
    and the alignment segment's up axis."""
    segs = rec.group_segments(group)
    out = [(segs[0], (2,))] if alignment_up else []
    return out + [(seg, (0, 1, 2)) for seg in segs[2::2]]


def solve_equations(a: np.ndarray, b: np.ndarray, covariance: np.ndarray):
    """Generalised least squares for the 21 error terms in natural scaling; raises on rank deficiency.

    Returns ``(x, covariance, variance_factor)`` in SI (scale factors relative): the formal covariance
    of the estimate under the equations' ``covariance``, and the residual chi-square per degree of
    freedom (1 when the noise model fits).
    """
    whiten = np.linalg.inv(np.linalg.cholesky(covariance))
    scaled = whiten @ a * NATURAL_SCALE
    b = whiten @ b
    m = len(b)
    u, s, vt = np.linalg.svd(scaled, full_matrices=False)
    if m < N_PARAMS or s[-1] < 1e-9 * s[0]:
        weak = np.abs(vt[-1]) > 0.3 if m >= N_PARAMS else np.ones(N_PARAMS, bool)
        names = ", ".join(np.array(NAMES)[weak])
        raise CalibrationError(f"the {m} equations do not determine all 21 parameters "
                               f"(condition {s[0] / max(s[-1], 1e-300):.2g}); not observable from this "
                               f"schedule: {names}")
    x_nat = vt.T @ ((u.T @ b) / s)
    residual = b - scaled @ x_nat
    dof = max(m - N_PARAMS, 1)
    cov_nat = (vt.T / s**2) @ vt
    scale = NATURAL_SCALE
    return x_nat * scale, cov_nat * np.outer(scale, scale), float(residual @ residual) / dof
