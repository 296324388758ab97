"""The paper's reference solver: iterative linear least squares (Kang et al. 2013, section 1).

Each iteration:

1. navigate every group from its coarse alignment (eq. 14) with the current
   parameters;
2. in the static segment after each rotation, fit the north and east
   velocity errors with ``a + b tau + c tau^2`` and the up velocity error with
   ``a + b tau`` (``tau`` from the start of the segment); the linear and
   quadratic coefficients (north quadratic optional) are the equations,
   5 per rotation, 45 for the paper's 9 rotations; by default also the slope
   of the up velocity in each group's alignment segment, which the paper
   leaves unused (48 equations; ``paper_equations=True`` for exactly 45);
3. the same fits applied to the sensitivities of the velocity error to the
   21 error terms (``T_g, eps, T_a, Delta``), propagated through the linear
   error model (eqs. 13-21) along the navigated attitude with the alignment
   errors of eq. 15 (:mod:`errormodel`), give the design matrix;
4. weighted least squares for the 21 errors, then the output model is
   corrected with eqs. 22-25, and the whole is repeated until every
   correction is below ``tolerance`` times its own sigma, or below
   :data:`ABSOLUTE_TOLERANCE` in natural units.

Weights: the equations of one segment and axis are whitened with the
covariance of the fitted coefficients under a velocity random walk (white
accelerometer noise), so linear and quadratic terms count by their real
precision.  ``sigma`` of the table is the formal standard error of this
weighted fit, scaled by the residual variance (48 - 21 = 27 degrees of
freedom for the paper's schedule); it does not include the correlation
between segments through the gyro-noise tilt random walk.
"""

from __future__ import annotations

import time
from typing import Callable

import numpy as np

from . import parameters as P
from .errormodel import velocity_sensitivity
from .initial import rough_parameters
from .recording import Recording
from .result import CalibrationError, CalibrationResult
from .strapdown import navigate_group

#: Corrections below these (natural units: ug, ppm, arcsec, deg/h) end the iteration regardless of sigma.
ABSOLUTE_TOLERANCE = np.where(
    np.isin(np.array(P.NATURAL_UNITS), ["deg/h"]), 1e-5, 1e-3
)

SIGMA_MEANING = ("1-sigma formal standard error of the weighted least squares of the last iteration, "
                 "scaled by its residual variance")


def _coefficient_operator(n: int, dt: float, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows mapping a velocity series to its polynomial slope/curvature, and their random-walk covariance.

    Returns ``(rows, cov)``: ``rows`` (degree, n) gives (b, c) of ``a + b tau + c tau^2``
    (SI: m/s^2, m/s^3); ``cov`` is their covariance for a unit-intensity
    random walk (variance ``tau`` m^2/s^2 at ``tau`` seconds).
    """
    tau = (np.arange(n) + 1) * dt
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


def build_equations(rec: Recording, params: np.ndarray, north_quadratic: bool = True,
                    alignment_up: bool = True):
    """The paper's equations for the current parameters: ``(A, b, labels)``, already whitened.

    ``alignment_up`` adds the slope of the up velocity in each group's first (alignment) static
    segment: the alignment takes only the tilt from it, and without it a schedule whose other
    positions never turn an accelerometer up (the paper's y axis) separates its bias and scale
    factor poorly.

    ``A`` (m, 21) maps the error terms (SI, ordered like :data:`parameters.NAMES`) to the whitened
    coefficients, ``b`` (m,) are the whitened coefficients of the navigated velocity.
    """
    rows, rhs, labels = [], [], []
    for group in rec.group_ids:
        nav = navigate_group(rec, group, params)
        sens = velocity_sensitivity(rec, nav, params)
        segs = rec.group_segments(group)
        statics = ([segs[0]] if alignment_up else []) + list(segs[2::2])
        for seg in statics:
            sl = rec.segment_samples(seg)
            local = slice(sl.start - nav.samples.start, sl.stop - nav.samples.start)
            n = local.stop - local.start
            axes = "U" if seg is segs[0] else "ENU"
            for axis, name in enumerate("ENU"):
                if name not in axes:
                    continue
                degree = 1 if name == "U" else 2
                ops, cov = _coefficient_operator(n, rec.dt, degree)
                if name == "N" and not north_quadratic:
                    ops, cov = ops[:1], cov[:1, :1]
                whiten = np.linalg.inv(np.linalg.cholesky(cov))
                before = local.start - 1
                velocity = nav.velocity[local, axis] - (nav.velocity[before, axis] if before >= 0 else 0.0)
                sensitivity = sens[local, axis, :] - (sens[before, axis, :] if before >= 0 else 0.0)
                rows.append(whiten @ (ops @ sensitivity))
                rhs.append(whiten @ (ops @ velocity))
                kinds = ["slope", "curvature"][: len(ops)]
                labels += [f"segment {seg.number} ({seg.orientation}) v_{name} {k}" for k in kinds]
    return np.vstack(rows), np.concatenate(rhs), labels


def solve_equations(a: np.ndarray, b: np.ndarray):
    """Least squares for the 21 error terms in natural scaling; raises on rank deficiency.

    Returns ``(x, covariance, residual_rms)`` in SI (scale factors relative).
    """
    scaled = a * P.NATURAL_SCALE
    m = len(b)
    u, s, vt = np.linalg.svd(scaled, full_matrices=False)
    if m < P.N_PARAMS or s[-1] < 1e-9 * s[0]:
        weak = np.abs(vt[-1]) > 0.3 if m >= P.N_PARAMS else np.ones(P.N_PARAMS, bool)
        names = ", ".join(np.array(P.NAMES)[weak])
        raise CalibrationError(f"the {m} equations do not determine all 21 parameters "
                               f"(condition {s[0] / max(s[-1], 1e-300):.2g}); not observable from this "
                               f"schedule: {names}")
    x_nat = vt.T @ ((u.T @ b) / s)
    residual = b - scaled @ x_nat
    dof = max(m - P.N_PARAMS, 1)
    variance = float(residual @ residual) / dof
    cov_nat = (vt.T / s**2) @ vt * variance
    scale = P.NATURAL_SCALE
    return x_nat * scale, cov_nat * np.outer(scale, scale), float(np.sqrt(variance))


def calibrate_ils(rec: Recording, initial: P.ParameterSet | None = None, max_iterations: int = 10,
                  tolerance: float = 0.01, north_quadratic: bool = True, paper_equations: bool = False,
                  progress: Callable[[str], None] | None = None) -> CalibrationResult:
    """Calibrate a recording with the paper's iterative least squares.

    Parameters
    ----------
    rec : Recording
    initial : ParameterSet, optional
        Starting values; default the paper's rough initial values (section 1.3).
    max_iterations : int
    tolerance : float
        Stop when every correction is below ``tolerance`` times its sigma.
    north_quadratic : bool
        Use the north quadratic term (the paper allows leaving it out).
    paper_equations : bool
        Exactly the paper's 5 equations per rotation; by default the up-velocity slope of each
        group's alignment segment is added (see :func:`build_equations`).
    progress : callable, optional
        Receives one line per iteration.

    Raises
    ------
    CalibrationError
        When the equations are rank deficient or the iteration does not converge.
    """
    t_start = time.perf_counter()
    initial = initial or rough_parameters(rec)
    params = initial.values.copy()
    history = [params.copy()]
    corrections = []
    converged = False
    for iteration in range(1, max_iterations + 1):
        a, b, labels = build_equations(rec, params, north_quadratic, alignment_up=not paper_equations)
        x, cov, rms = solve_equations(a, b)
        params = P.apply_error_estimate(params, x)
        history.append(params.copy())
        sigma = np.sqrt(np.diag(cov))
        ratio = np.abs(x) / np.where(sigma > 0, sigma, np.inf)
        small = (ratio < tolerance) | (np.abs(x) / P.NATURAL_SCALE < ABSOLUTE_TOLERANCE)
        corrections.append(x / P.NATURAL_SCALE)
        if progress:
            worst = int(np.argmax(ratio))
            progress(f"ils iteration {iteration}: {len(b)} equations, largest correction "
                     f"{P.NAMES[worst]} {x[worst] / P.NATURAL_SCALE[worst]:+.4g} {P.NATURAL_UNITS[worst]} "
                     f"({ratio[worst]:.3g} sigma), residual rms {rms:.3g}")
        if not np.all(np.isfinite(params)):
            raise CalibrationError(f"iteration {iteration} produced non-finite parameters")
        if np.all(small):
            converged = True
            break
    if not converged:
        raise CalibrationError(f"the iterative least squares did not converge in {max_iterations} iterations "
                               f"(last corrections up to {np.max(ratio):.3g} sigma)")
    covariance = _covariance_of_values(params, cov)
    result = P.ParameterSet(params, covariance=covariance)
    return CalibrationResult("ils", result, initial, history, iteration, converged, rms,
                             time.perf_counter() - t_start, SIGMA_MEANING,
                             {"corrections_natural": corrections, "equations": len(b), "labels": labels})


def _covariance_of_values(params: np.ndarray, error_cov: np.ndarray) -> np.ndarray:
    """Covariance of the parameter values from that of the error terms (scale: S = S_hat/(1+t))."""
    jac = np.ones(P.N_PARAMS)
    jac[P.SCALE_MASK] = -params[P.SCALE_MASK]
    return error_cov * np.outer(jac, jac)
