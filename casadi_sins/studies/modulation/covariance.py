"""Covariance propagation of the error state along a rotation scheme, discretised piece by piece.

The dynamics are piecewise: constant during a dwell, a known function of time during a constant-rate
turn.  Each distinct piece (same start attitude, axis, rate and length) is discretised once and reused
in every period (Guan et al. 2023, eqs. 9-19: ``X_k = Phi X_{k-1} + W``):

* dwell: ``Phi = expm(F T)`` and the noise ``Q_d`` by Van Loan's method, exact;
* turn: sub-steps of at most ``step_deg``; ``Phi`` of each by the fourth-order Magnus integrator on
  Gauss-Legendre nodes (``Omega = h/2 (A1 + A2) + sqrt(3) h^2/12 [A2, A1]``), ``Q_d`` by Van Loan at the
  sub-step's middle.

What is propagated is the transition matrix itself, ``Phi(t_k, 0)``, and the two noise covariances.
The position and velocity rows of ``Phi(t_k, 0)`` are the sensitivities of the navigation error to
every initial state, so any source's contribution (Guan et al. 2023, eqs. 20-22 and 26-30: the
covariance splits into the terms of the independent initial errors and noises) is
``S_k P0_source S_k^T``; the total uses the full initial covariance (correlations kept).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...core.earth import Site
from ...core.errors import InputError
from ...core.linalg import expm
from . import model as M
from .schemes import Piece, Scheme, check_size, scheme_pieces

#: Sub-steps per turn below this many per 90 deg are refused (the turn integrals lose accuracy).
MIN_STEPS_PER_90 = 4
#: Sub-steps finer than this (deg) only cost time (1 deg already agrees with 5 deg to 1e-6).
MIN_STEP_DEG = 0.01
#: Rows of the recorded sensitivities: dv_E, dv_N (m/s), north and east position (m).
OUT_ROWS = ("v_east", "v_north", "north", "east")


@dataclasses.dataclass
class Propagation:
    """Sensitivities and noise covariances of velocity and position at the output times.

    Attributes
    ----------
    time : ndarray (T,)
        Output times, s.
    sensitivity : ndarray (T, 4, 31)
        ``d(v_E, v_N, north, east)/d(x0)``, m/s and m per SI unit of each initial state.
    noise : dict of str -> ndarray (T, 4, 4)
        ``"gyro noise"`` and ``"accel noise"``: their covariance of the same four.
    """

    time: np.ndarray
    sensitivity: np.ndarray
    noise: dict[str, np.ndarray]

    def covariance(self, p0: np.ndarray, noises=("gyro noise", "accel noise")) -> np.ndarray:
        """(T, 4, 4) covariance of (v_E, v_N, north, east) from an initial covariance and chosen noises
        (``P_n = Phi^n P_0 Phi^nT + sum Phi^i Q Phi^iT``, Guan et al. 2023, eqs. 9-22)."""
        s = self.sensitivity
        cov = np.einsum("tij,jk,tlk->til", s, p0, s, optimize=True)
        for name in noises:
            cov = cov + self.noise[name]
        return cov

    def mean(self, x0: np.ndarray) -> np.ndarray:
        """(T, 4) noise-free error from an initial error state ``x0`` (a deterministic run)."""
        return self.sensitivity @ x0


def _van_loan(f: np.ndarray, s: np.ndarray, h: float) -> np.ndarray:
    """``Q_d = int_0^h e^{F t} S e^{F' t} dt`` (Van Loan 1978)."""
    n = len(f)
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n] = -f
    block[:n, n:] = s
    block[n:, n:] = f.T
    ex = expm(block * h)
    phi = ex[n:, n:].T
    return phi @ ex[:n, n:]


def turn_substeps(piece: Piece, step_deg: float) -> int:
    """Sub-steps of a turn of at most ``step_deg`` each (one for a dwell)."""
    return max(1, math.ceil(abs(piece.rate) * piece.duration / math.radians(step_deg) - 1e-9))


def discretise(piece: Piece, site: Site, nav: np.ndarray, gyro_arw, accel_vrw, step_deg: float):
    """``(Phi, Q_gyro, Q_accel)`` of one piece (Guan et al. 2023, eqs. 9-19: ``X_k = Phi X_{k-1} + W``)."""
    if piece.axis is None:
        f = M.error_matrix(nav, site, piece.attitude, np.zeros(3))
        s_g, s_a = M.noise_inputs(piece.attitude, gyro_arw, accel_vrw)
        return expm(f * piece.duration), _van_loan(f, s_g, piece.duration), _van_loan(f, s_a, piece.duration)
    n = turn_substeps(piece, step_deg)
    h = piece.duration / n
    rate = piece.table_rate()
    nodes = h * (0.5 + np.array([-1.0, 1.0]) * math.sqrt(3.0) / 6.0)
    phi, q_g, q_a = np.eye(M.N_STATE), np.zeros((M.N_STATE, M.N_STATE)), np.zeros((M.N_STATE, M.N_STATE))
    for k in range(n):
        c1, c2, cm = piece.attitude_at(k * h + np.array([nodes[0], nodes[1], h / 2]))
        a1, a2 = M.error_matrix(nav, site, c1, rate), M.error_matrix(nav, site, c2, rate)
        omega = h / 2 * (a1 + a2) + math.sqrt(3.0) * h * h / 12.0 * (a2 @ a1 - a1 @ a2)
        step = expm(omega)
        fm = M.error_matrix(nav, site, cm, rate)
        s_g, s_a = M.noise_inputs(cm, gyro_arw, accel_vrw)
        phi = step @ phi
        q_g = step @ q_g @ step.T + _van_loan(fm, s_g, h)
        q_a = step @ q_a @ step.T + _van_loan(fm, s_a, h)
    return phi, q_g, q_a


def _key(piece: Piece, duration: float) -> tuple:
    axis = None if piece.axis is None else tuple(np.round(piece.axis, 12))
    return (np.round(piece.attitude, 12).tobytes(), axis, round(piece.rate, 15), round(duration, 9))


def output_pieces(pieces: list[Piece], max_step_s: float) -> list[Piece]:
    """Dwells cut into chunks of at most ``max_step_s`` (output resolution); turns kept whole."""
    out = []
    for p in pieces:
        if p.axis is not None or p.duration <= max_step_s * (1 + 1e-9):
            out.append(p)
            continue
        n = math.ceil(p.duration / max_step_s - 1e-9)
        h = p.duration / n
        out.extend(dataclasses.replace(p, t0=p.t0 + k * h, duration=h) for k in range(n))
    return out


def check_turn_step(step_deg: float, what: str) -> None:
    """Refuse a turn sub-step that is too coarse (fewer than :data:`MIN_STEPS_PER_90` per 90 deg) or
    finer than :data:`MIN_STEP_DEG`.

    Raises
    ------
    InputError
    """
    if not (np.isfinite(step_deg) and step_deg <= 90.0 / MIN_STEPS_PER_90):
        raise InputError(None, f"{what} {step_deg:g} deg gives too few steps per turn "
                         f"(at least {MIN_STEPS_PER_90} per 90 deg: step <= {90 / MIN_STEPS_PER_90:g} deg)")
    if not step_deg >= MIN_STEP_DEG:
        raise InputError(None, f"{what} {step_deg:g} deg is below {MIN_STEP_DEG:g} deg (no more accurate, only slower)")


def check_run(scheme: Scheme, site: Site, hours: float, max_step_s: float) -> None:
    """Refuse a run length, output step or site the propagation cannot take, before any work.

    Raises
    ------
    InputError
        Naming the value (or the scheme file) at fault.
    """
    if not (np.isfinite(hours) and hours > 0):
        raise InputError(None, f"hours must be a positive number (got {hours})")
    if not (np.isfinite(max_step_s) and max_step_s > 0):
        raise InputError(None, f"output step must be a positive number of seconds (got {max_step_s})")
    M.check_site(site)
    check_size(scheme, hours * 3600.0, max_step_s)


def propagate(scheme: Scheme, site: Site, hours: float, gyro_arw, accel_vrw, step_deg: float = 5.0,
              max_step_s: float = 60.0, cache: dict | None = None) -> Propagation:
    """Propagate the transition matrix and the noise covariances along ``scheme`` for ``hours``.

    Parameters
    ----------
    gyro_arw, accel_vrw : array (3,)
        White-noise densities, rad/sqrt(s) and m/s/sqrt(s).
    step_deg : float
        Largest integration sub-step of a turn, deg (at least :data:`MIN_STEPS_PER_90` per 90 deg).
    max_step_s : float
        Largest output interval in a dwell, s.
    cache : dict, optional
        The discretised pieces, shared between calls of the same site, noise and ``step_deg`` (schemes
        made of the same turns, as a design search's candidates, then cost only their products).
    """
    check_turn_step(step_deg, "turn integration step")
    check_run(scheme, site, hours, max_step_s)
    nav = M.navigation_block(site)
    pieces = output_pieces(scheme_pieces(scheme, hours * 3600.0), max_step_s)
    cache = {} if cache is None else cache
    n, t_out = M.N_STATE, len(pieces) + 1
    sens = np.zeros((t_out, 4, n))
    noise = {"gyro noise": np.zeros((t_out, 4, 4)), "accel noise": np.zeros((t_out, 4, 4))}
    time = np.zeros(t_out)
    phi_acc = np.eye(n)
    p_g, p_a = np.zeros((n, n)), np.zeros((n, n))
    rows = [3, 4, 5, 6]
    scale = np.array([1.0, 1.0, *M.to_metres(site)])[:, None]
    sens[0] = phi_acc[rows] * scale
    for k, piece in enumerate(pieces, start=1):
        key = _key(piece, piece.duration)
        if key not in cache:
            cache[key] = discretise(piece, site, nav, gyro_arw, accel_vrw, step_deg)
        phi, q_g, q_a = cache[key]
        phi_acc = phi @ phi_acc
        p_g = phi @ p_g @ phi.T + q_g
        p_a = phi @ p_a @ phi.T + q_a
        time[k] = piece.t0 + piece.duration
        sens[k] = phi_acc[rows] * scale
        noise["gyro noise"][k] = p_g[np.ix_(rows, rows)] * (scale @ scale.T)
        noise["accel noise"][k] = p_a[np.ix_(rows, rows)] * (scale @ scale.T)
    return Propagation(time, sens, noise)
