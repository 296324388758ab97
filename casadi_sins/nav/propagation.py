"""Covariance propagation of the navigation error state along the IMU's motion, piece by piece.

The dynamics are those of :class:`nav.errorstate.ErrorModel` at the IMU's attitude and turntable rate:
constant while the IMU is still, a known function of time while it turns.  Each piece of the motion is
discretised once (Guan et al. 2023, eqs. 9-19: ``X_k = Phi X_{k-1} + W``) and reused wherever the same piece
recurs (the periods of a rotation scheme, the minutes of a static budget):

* still: ``Phi = expm(F T)`` and the noise ``Q_d`` by Van Loan's method, exact;
* turn: sub-steps of at most ``step`` rad of turn; ``Phi`` of each by the fourth-order Magnus integrator on
  the two Gauss-Legendre nodes (``Omega = h/2 (A1 + A2) + sqrt(3) h^2/12 [A2, A1]``), ``Q_d`` by Van Loan at
  the sub-step's middle.

What is propagated is the transition matrix itself, ``Phi(t_k, 0)``, and the two noise covariances.  The
velocity and position rows of ``Phi(t_k, 0)`` are the sensitivities of the navigation error to every
initial state, so any source's contribution (Guan et al. 2023, eqs. 20-22 and 26-30: the covariance splits
into the terms of independent initial errors and noises) is ``S_k P0_source S_k^T``; the total uses the whole
initial covariance (correlations kept).

A piece is a motion piece (:class:`sim.motion.MotionPiece`): ``t0``, ``t1``, the attitude ``C_b^n`` at
``t0``, a turn axis in the body (``None`` while still) and angle, ``attitude_at(t)`` and ``rate_at(t)``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.linalg import expm
from .errorstate import DV, POS, ErrorModel

#: Rows of the recorded sensitivities: dv_E, dv_N (m/s), north and east position (m).
OUT_ROWS = ("v_east", "v_north", "north", "east")
_ROWS = [DV.start, DV.start + 1, POS.start, POS.start + 1]
NOISES = ("gyro noise", "accel noise")


@dataclasses.dataclass
class Propagation:
    """Sensitivities and noise covariances of velocity and position at the output times.

    Attributes
    ----------
    time : ndarray (T,)
        Output times, s.
    sensitivity : ndarray (T, 4, n)
        ``d(v_E, v_N, north, east)/d(x0)``, m/s and m per SI unit of each initial state.
    noise : dict of str -> ndarray (T, 4, 4)
        ``"gyro noise"`` and ``"accel noise"``: their covariance of the same four.
    """

    time: np.ndarray
    sensitivity: np.ndarray
    noise: dict[str, np.ndarray]

    def covariance(self, p0: np.ndarray, noises=NOISES) -> np.ndarray:
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


def van_loan(f: np.ndarray, s: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Phi, Q_d)`` over ``h``: ``Phi = e^{F h}`` and ``Q_d = int_0^h e^{F t} S e^{F' t} dt`` (Van Loan 1978)."""
    n = len(f)
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n] = -f
    block[:n, n:] = s
    block[n:, n:] = f.T
    ex = expm(block * h)
    phi = ex[n:, n:].T
    return phi, phi @ ex[:n, n:]


def magnus_step(a1: np.ndarray, a2: np.ndarray, h: float) -> np.ndarray:
    """The transition matrix over ``h`` of ``x' = A(t) x`` from ``A`` at the two Gauss-Legendre nodes
    (fourth-order Magnus: ``Omega = h/2 (A1 + A2) + sqrt(3) h^2/12 [A2, A1]``)."""
    return expm(h / 2 * (a1 + a2) + math.sqrt(3.0) * h * h / 12.0 * (a2 @ a1 - a1 @ a2))


def substeps(piece, step: float) -> int:
    """Sub-steps of a piece: of at most ``step`` rad of turn each (one for a still piece)."""
    return 1 if piece.axis is None else max(1, math.ceil(abs(piece.angle) / step - 1e-9))


def discretise(model: ErrorModel, piece, gyro_arw, accel_vrw, step: float):
    """``(Phi, Q_gyro, Q_accel)`` of one piece (module docstring); noise densities per body axis
    (rad/sqrt(s), m/s/sqrt(s)), turn sub-steps of at most ``step`` rad."""
    duration = piece.t1 - piece.t0
    if piece.axis is None:
        f = model.matrix(piece.attitude)
        s_g, s_a = model.noise(piece.attitude, gyro_arw, accel_vrw)
        phi, q_g = van_loan(f, s_g, duration)
        return phi, q_g, van_loan(f, s_a, duration)[1]
    n = substeps(piece, step)
    h = duration / n
    nodes = h * (0.5 + np.array([-1.0, 1.0]) * math.sqrt(3.0) / 6.0)
    phi, q_g, q_a = (np.eye(model.n_state), np.zeros((model.n_state, model.n_state)),
                     np.zeros((model.n_state, model.n_state)))
    for k in range(n):
        times = piece.t0 + k * h + np.array([nodes[0], nodes[1], h / 2])
        c1, c2, cm = piece.attitude_at(times)
        r1, r2, rm = (piece.rate_at(times)[:, None] * piece.axis)
        step_phi = magnus_step(model.matrix(c1, r1), model.matrix(c2, r2), h)
        fm = model.matrix(cm, rm)
        s_g, s_a = model.noise(cm, gyro_arw, accel_vrw)
        phi = step_phi @ phi
        q_g = step_phi @ q_g @ step_phi.T + van_loan(fm, s_g, h)[1]
        q_a = step_phi @ q_a @ step_phi.T + van_loan(fm, s_a, h)[1]
    return phi, q_g, q_a


def piece_key(piece) -> tuple:
    """What makes two pieces' discretisations equal: start attitude, axis, angle, length and rate profile."""
    axis = None if piece.axis is None else tuple(np.round(piece.axis, 12))
    return (np.round(piece.attitude, 12).tobytes(), axis, round(piece.angle, 15), round(piece.t1 - piece.t0, 9),
            getattr(piece, "profile", None))


def output_pieces(pieces, max_step_s: float) -> list:
    """Still pieces cut into equal parts of at most ``max_step_s`` (the output resolution); turns kept whole."""
    out = []
    for p in pieces:
        duration = p.t1 - p.t0
        if p.axis is not None or duration <= max_step_s * (1 + 1e-9):
            out.append(p)
            continue
        n = math.ceil(duration / max_step_s - 1e-9)
        h = duration / n
        out.extend(p.part(p.t0 + k * h, p.t0 + (k + 1) * h) for k in range(n))
    return out


def propagate(model: ErrorModel, pieces, gyro_arw, accel_vrw, step: float, cache: dict | None = None,
              progress=None) -> Propagation:
    """Propagate the transition matrix and the noise covariances over consecutive ``pieces``; one output
    at the start and at the end of every piece.

    Parameters
    ----------
    model : ErrorModel
    pieces : list of motion pieces
    gyro_arw, accel_vrw : array (3,)
        White-noise densities, rad/sqrt(s) and m/s/sqrt(s).
    step : float
        Largest sub-step of a turn, rad.
    cache : dict, optional
        The discretised pieces, shared between calls of the same model, noise and ``step`` (schemes made of
        the same turns, as a design search's candidates, then cost only their products).
    progress : callable, optional
        ``progress(fraction)`` of the pieces done.
    """
    cache = {} if cache is None else cache
    n, t_out = model.n_state, len(pieces) + 1
    sens = np.zeros((t_out, 4, n))
    noise = {name: np.zeros((t_out, 4, 4)) for name in NOISES}
    time = np.zeros(t_out)
    phi_acc = np.eye(n)
    p_g, p_a = np.zeros((n, n)), np.zeros((n, n))
    scale = np.array([1.0, 1.0, *model.to_metres()])[:, None]
    time[0], sens[0] = pieces[0].t0 if pieces else 0.0, phi_acc[_ROWS] * scale
    for k, piece in enumerate(pieces, start=1):
        key = piece_key(piece)
        if key not in cache:
            cache[key] = discretise(model, piece, gyro_arw, accel_vrw, step)
        phi, q_g, q_a = cache[key]
        phi_acc = phi @ phi_acc
        p_g = phi @ p_g @ phi.T + q_g
        p_a = phi @ p_a @ phi.T + q_a
        time[k] = piece.t1
        sens[k] = phi_acc[_ROWS] * scale
        noise["gyro noise"][k] = p_g[np.ix_(_ROWS, _ROWS)] * (scale @ scale.T)
        noise["accel noise"][k] = p_a[np.ix_(_ROWS, _ROWS)] * (scale @ scale.T)
        if progress is not None:
            progress(k / len(pieces))
    return Propagation(time, sens, noise)
