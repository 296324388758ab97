"""The period-mean tilt: what sets a modulated system's position error.

Under a rotation scheme the attitude error ``phi(t) = phi_0 - int_0^t C d_w dt`` (Yu and Ruan 2014,
eqs. 5-7, the Earth-rate and Schuler couplings left out over one period) oscillates about a mean that is
NOT zero: it starts at ``phi_0`` and the integral of the modulated drift is a ramp-and-return that never
goes negative on the average.  A constant tilt drives the Schuler loop: the position error swings between
0 and about ``2 R x (mean tilt)`` (``dv' = f^n x phi``, ``R`` the Earth's radius), so the period-mean tilt
predicts the position error of the 24 h covariance; the residual drift (:mod:`.residual`) adds a ramp.
The accelerometers enter as an equivalent tilt: ``dv_E' = -g (phi_N - df_E / g)``,
``dv_N' = g (phi_E + df_N / g)``, so ``(df_N / g, -df_E / g)`` with ``df = C d_f`` (its period mean).

Everything is linear in the initial error states (:mod:`.model`, the parameters ``names``): the functions
return ``(3, n)`` matrices (per unit of each state), and :func:`mean_tilt_table` the per-term figures of
``modulation.json``.

The integral of ``theta(t) = int_0^t g`` over a piece of length ``L`` is
``L theta(0) + int_0^L (L - s) g(s) ds``: one quadrature per piece (6-point Gauss-Legendre on at most 5 deg
of a turn, exact for a dwell).
"""

from __future__ import annotations

import math

import numpy as np

from ...core import earth, units
from ...core.earth import Site
from ...nav.errorinputs import body_motion, error_columns
from ...sim.motion import MotionPiece
from . import model as M
from .residual import nav_frame_error, quadrature
from .schemes import Scheme, period_pieces, still


def mean_radius(site: Site) -> float:
    """``sqrt((R_M + h)(R_N + h))``, m: metres of position per radian of tilt."""
    r_m, r_n = earth.earth_radii(site.latitude)
    return float(math.sqrt((r_m + site.height) * (r_n + site.height)))


def piece_moments(piece: MotionPiece, site: Site, names=M.SHEET_NAMES
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(G, W, A)`` of one piece, each (3, n) per unit sensor state (the parameters ``names``).

    ``G = int C d_w dt`` (the tilt it adds), ``W = int (L - s) C d_w(s) ds`` (its share of the integral of
    the tilt), ``A = int C d_f dt`` (the specific-force error it integrates).
    """
    tau, weights = quadrature(piece, piece.duration)
    g = nav_frame_error(piece, site, tau, "total", names)
    times = piece.t0 + tau
    c = piece.attitude_at(times)
    a = c @ error_columns(names, *body_motion(c, site.earth_rate, site.g, piece.turn_rate(times)))[1]
    return (np.einsum("n,nij->ij", weights, g), np.einsum("n,nij->ij", weights * (piece.duration - tau), g),
            np.einsum("n,nij->ij", weights, a))


def equivalent_tilt(gyro_integral: np.ndarray, accel_mean: np.ndarray, g: float) -> np.ndarray:
    """The tilt (3, n) of a mean gyro-integral and a mean specific-force error: ``-theta`` plus
    ``(df_N / g, -df_E / g, 0)``."""
    tilt = -gyro_integral.copy()
    tilt[0] += accel_mean[1] / g
    tilt[1] -= accel_mean[0] / g
    return tilt


def first_period(scheme: Scheme) -> list[MotionPiece]:
    """The pieces from time zero to the end of the first period: the initial dwell, then one period."""
    pieces = [still(0.0, scheme.initial_dwell, scheme.start)] if scheme.initial_dwell > 0 else []
    if scheme.steps:
        pieces += period_pieces(scheme, scheme.start, scheme.initial_dwell)
    return pieces


def mean_tilt(scheme: Scheme, site: Site, names=M.SHEET_NAMES) -> np.ndarray:
    """The mean attitude error over the first period (3, n), per unit of each initial state (rad/unit).

    The initial attitude error is its own mean (identity block); the velocity and position columns are
    zero.  A scheme needs steps (a strapdown IMU has no period: its tilt grows without bound).
    """
    n = len(names)
    out = np.zeros((3, M.N_NAV + n))
    out[:, M.PHI] = np.eye(3)
    theta, total, accel, length = np.zeros((3, n)), np.zeros((3, n)), np.zeros((3, n)), 0.0
    for piece in first_period(scheme):
        g, w, a = piece_moments(piece, site, names)
        total += piece.duration * theta + w
        theta = theta + g
        accel += a
        length += piece.duration
    out[:, M.N_NAV:] = equivalent_tilt(total / length, accel / length, site.g)
    return out


def mean_tilt_table(scheme: Scheme, sources, site: Site) -> dict | None:
    """Per error term: its 1-sigma period-mean tilt (arcsec, E N U) and ``2 R |tilt_h|`` (m); the total's
    ``2 R sqrt(tr(M_h P M_h^T))`` (m), the prediction of the covariance's maximum horizontal error when no
    residual drift ramps.  None for a strapdown scheme (no period)."""
    if not scheme.steps:
        return None
    m = mean_tilt(scheme, site, sources.names) @ sources.initial_map()
    sigma = np.sqrt(np.clip(np.diag(sources.p0), 0.0, None))
    two_r = 2.0 * mean_radius(site)
    terms = {}
    for i, name in enumerate(sources.state_names):
        if sigma[i] > 0 and not 3 <= i < M.N_NAV:
            tilt = m[:, i] * sigma[i]
            terms[name] = {"tilt_arcsec": ((tilt / units.ARCSEC).round(5) + 0.0).tolist(),
                           "two_r_horizontal_m": round(float(two_r * np.hypot(*tilt[:2])), 3)}
    total = two_r * math.sqrt(max(float(np.trace(m[:2] @ sources.p0 @ m[:2].T)), 0.0))
    return {"terms": terms, "two_r_horizontal_total_m": round(total, 3)}
