"""The motion of a session by hand (a problem's ``[hand]``): rests at random orientations, free moves, tremor.

Rest ``k`` holds attitude ``A_k`` (uniformly random) at position ``p_k``.  The move from rest ``k`` to rest
``k+1`` (duration ``T``, ``tau = (t - t0) / T``) turns the body by

    r(tau) = theta s(tau) + sum_m b_m sin(m pi tau) sin(pi tau)^2,     C(t) = A_k exp([r x])

with ``theta`` the rotation vector from ``A_k`` to ``A_{k+1}`` (less the settle, below), ``s`` the minimum-jerk
law ``10 tau^3 - 15 tau^4 + 6 tau^5`` and random wobbles ``b_m`` (m = 1..3) scaled so that the peak rate
is the move's draw from ``peak_rate_deg_s``: the axis wanders, the rate is never a clean profile.  The
position follows ``p_k + d s(tau)`` plus its own wobble.  The last ``settle_deg`` of each turn is crept into
the next rest, ``e (1 - (1 + u) exp(-u))`` with ``u = (t - t1) / settle_s``: a rest begins while the hand
still settles.  In the rests the hand trembles: three sinusoids of ``tremor_hz`` in angle and in position,
faded in and out over :data:`TREMOR_FADE_S`, with rms ``tremor_deg`` and a linear acceleration of rms
``tremor_mg``.

The body rate is ``J_r(r) dr/dt`` plus the Earth rate, the specific force ``C^T (p'' + g)`` (the navigation
frame is the site's ENU; Coriolis terms of a hand's speed, ~1e-4 m/s^2, are left out); both are
integrated over each true sample interval by 6-point Gauss-Legendre quadrature.  With ``clock_jitter`` the
true sample instants scatter about the nominal ones (the time column stays uniform).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.rotations import rotation_matrices, rotation_vector
from ..data.problem import Problem

#: Seconds over which the tremor fades in and out at a rest's ends, and the step of the numerical derivatives.
TREMOR_FADE_S = 0.5
_H_RATE = 1e-6
_H_FORCE = 1e-4
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(6)


def _min_jerk(tau):
    tau = np.clip(tau, 0.0, 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def _wobble(tau, coefficients):
    """``sum_m b_m sin(m pi tau) sin(pi tau)^2``: zero with its first two derivatives at both ends."""
    tau = np.clip(tau, 0.0, 1.0)
    window = np.sin(np.pi * tau) ** 2
    return sum(np.outer(np.sin((m + 1) * np.pi * tau) * window, b) for m, b in enumerate(coefficients))


def random_attitude(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation matrix (a normalised Gaussian quaternion)."""
    q = rng.standard_normal(4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def attitude_in_cone(rng: np.random.Generator, first: np.ndarray, cone_deg: float) -> np.ndarray:
    """A random attitude whose gravity direction (body) lies within ``cone_deg`` of that of ``first``: a random
    heading, then a tilt about a random horizontal axis of up to the cone's angle (uniform on the cap)."""
    if cone_deg >= 180.0:
        return random_attitude(rng)
    tilt = np.arccos(1.0 - rng.uniform() * (1.0 - np.cos(np.radians(cone_deg))))
    azimuth = rng.uniform(0.0, 2.0 * np.pi)
    heading = rotation_matrices(np.array([0.0, 0.0, rng.uniform(0.0, 2.0 * np.pi)]))
    level = rotation_matrices(tilt * np.array([np.cos(azimuth), np.sin(azimuth), 0.0]))
    return level @ heading @ first


@dataclasses.dataclass
class Piece:
    """A rest or a move over ``[t0, t1]``: attitude ``A exp([r(t) x])``, position ``p(t)``."""

    t0: float
    t1: float
    attitude: np.ndarray
    position: np.ndarray
    turn: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))  # theta (moves)
    turn_wobble: tuple = ()
    shift: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))  # d (moves)
    shift_wobble: tuple = ()
    settle: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))  # crept in at a rest's start
    settle_s: float = 0.25
    tremor_angle: np.ndarray | None = None  # (3 components, 3) amplitudes
    tremor_position: np.ndarray | None = None
    tremor_hz: np.ndarray | None = None
    tremor_phase: np.ndarray | None = None

    @property
    def is_move(self) -> bool:
        return self.t1 > self.t0 and (np.any(self.turn) or bool(self.turn_wobble))

    def _tremor(self, t, amplitude):
        if amplitude is None:
            return np.zeros((len(t), 3))
        fade = np.clip(np.minimum(t - self.t0, self.t1 - t) / TREMOR_FADE_S, 0.0, 1.0)
        fade = fade**3 * (10.0 - 15.0 * fade + 6.0 * fade**2)
        waves = np.sin(2.0 * np.pi * self.tremor_hz[None, :] * t[:, None] + self.tremor_phase[None, :])
        return fade[:, None] * (waves @ amplitude)

    def rotation(self, t) -> np.ndarray:
        """``r(t)`` (N, 3)."""
        t = np.asarray(t, dtype=float)
        if self.is_move:
            tau = (t - self.t0) / (self.t1 - self.t0)
            return np.outer(_min_jerk(tau), self.turn) + _wobble(tau, self.turn_wobble)
        u = np.maximum(t - self.t0, 0.0) / self.settle_s
        creep = np.outer(1.0 - (1.0 + u) * np.exp(-u), self.settle) - self.settle  # -settle at t0, 0 later
        return creep + self._tremor(t, self.tremor_angle)

    def place(self, t) -> np.ndarray:
        """``p(t)`` (N, 3)."""
        t = np.asarray(t, dtype=float)
        if self.is_move:
            tau = (t - self.t0) / (self.t1 - self.t0)
            return self.position + np.outer(_min_jerk(tau), self.shift) + _wobble(tau, self.shift_wobble)
        return self.position + self._tremor(t, self.tremor_position)


@dataclasses.dataclass
class HandMotion:
    """The pieces of a session by hand, and what is true about it."""

    pieces: list[Piece]
    rest_attitudes: list[np.ndarray]
    peak_rates: list[float]  # rad/s, per move
    earth_rate: np.ndarray
    gravity: float

    def _index(self, t: np.ndarray) -> np.ndarray:
        starts = np.array([p.t0 for p in self.pieces])
        return np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.pieces) - 1)

    def kinematics(self, t):
        """``(C_b^n, w_b, w_dot_b, f_b)`` at times ``t`` (any shape): body rate with the Earth rate,
        specific force at the unit; the derivatives numerical."""
        t = np.asarray(t, dtype=float)
        flat = t.ravel()
        attitude, rate, force = self._state(flat)
        rate_dot = (self._state(flat + 1e-5)[1] - self._state(flat - 1e-5)[1]) / 2e-5
        shape = t.shape
        return (attitude.reshape(shape + (3, 3)), rate.reshape(shape + (3,)), rate_dot.reshape(shape + (3,)),
                force.reshape(shape + (3,)))

    def _state(self, flat: np.ndarray):
        attitude = np.empty(flat.shape + (3, 3))
        rate = np.empty(flat.shape + (3,))
        force = np.empty(flat.shape + (3,))
        index = self._index(flat)
        for k in np.unique(index):
            sel = index == k
            attitude[sel], rate[sel], force[sel] = self._piece_state(self.pieces[k], flat[sel])
        return attitude, rate, force

    def _piece_state(self, piece: Piece, t: np.ndarray):
        r = piece.rotation(t)
        r_dot = (piece.rotation(t + _H_RATE) - piece.rotation(t - _H_RATE)) / (2.0 * _H_RATE)
        attitude = piece.attitude @ rotation_matrices(r)
        relative = np.einsum("nij,nj->ni", _right_jacobian(r), r_dot)
        accel = (piece.place(t + _H_FORCE) - 2.0 * piece.place(t) + piece.place(t - _H_FORCE)) / _H_FORCE**2
        reference = accel + np.array([0.0, 0.0, self.gravity])
        body = np.swapaxes(attitude, -1, -2)
        return attitude, relative + body @ self.earth_rate, np.einsum("nji,nj->ni", attitude, reference)


def _right_jacobian(r: np.ndarray) -> np.ndarray:
    """``J_r(r)``: body rate ``J_r(r) r'`` of ``exp([r x])``, (N, 3, 3)."""
    theta2 = np.sum(r * r, axis=-1)[:, None, None]
    small = theta2 < 1e-12
    theta = np.sqrt(np.where(small, 1.0, theta2))
    a = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(theta)) / np.where(small, 1.0, theta2))
    b = np.where(small, 1.0 / 6.0 - theta2 / 120.0, (theta - np.sin(theta)) / (theta * np.where(small, 1.0, theta2)))
    x, y, z = r[:, 0], r[:, 1], r[:, 2]
    zero = np.zeros_like(x)
    k = np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)
    return np.eye(3) - a * k + b * (k @ k)


def plan_hand(problem: Problem, rng: np.random.Generator) -> HandMotion:
    """Draw the orientations, paths, translations and tremor of a ``[hand]`` problem (module docstring)."""
    hand = problem.hand
    segments = problem.segments()
    rests = [s for s in segments if s.is_static]
    moves = [s for s in segments if not s.is_static]
    attitudes = [random_attitude(rng)]
    positions = [np.zeros(3)]
    for _ in moves:
        attitudes.append(attitude_in_cone(rng, attitudes[0], hand.cone_deg))
        step = rng.standard_normal(3)
        step *= rng.uniform(*hand.translation_m) / np.linalg.norm(step)
        positions.append(positions[-1] + step - 0.5 * positions[-1])
    pieces: list[Piece] = []
    peaks: list[float] = []
    tremor_angle = np.radians(hand.tremor_deg)
    for k, rest in enumerate(rests):
        settle = np.zeros(3)
        if k:
            move = moves[k - 1]
            turn = rotation_vector(attitudes[k - 1].T @ attitudes[k])
            angle = float(np.linalg.norm(turn))
            settle = turn / max(angle, 1e-12) * min(np.radians(hand.settle_deg), 0.5 * angle)
            piece, peak = _move(move.start, move.end, attitudes[k - 1], positions[k - 1], turn - settle,
                                positions[k] - positions[k - 1], np.radians(rng.uniform(*hand.peak_rate_deg_s)), rng)
            pieces.append(piece)
            peaks.append(peak)
            start_attitude = attitudes[k - 1] @ rotation_matrices(turn - settle)
            attitudes[k] = start_attitude @ rotation_matrices(settle)  # the rest's attitude once settled
        else:
            start_attitude = attitudes[0]
        hz = rng.uniform(*hand.tremor_hz, size=3)
        angle_amp = _tremor_amplitudes(rng, tremor_angle)
        linear_amp = _tremor_amplitudes(rng, hand.tremor_mg * 9.80665e-3) / (2.0 * np.pi * hz[:, None]) ** 2
        pieces.append(Piece(rest.start, rest.end, start_attitude @ rotation_matrices(settle), positions[k],
                            settle=settle, settle_s=hand.settle_s, tremor_angle=angle_amp, tremor_position=linear_amp,
                            tremor_hz=hz, tremor_phase=rng.uniform(0.0, 2.0 * np.pi, size=3)))
    return HandMotion(pieces, attitudes, peaks, problem.site.earth_rate, problem.site.g)


def _tremor_amplitudes(rng: np.random.Generator, rms: float) -> np.ndarray:
    """Three sinusoids' amplitude vectors whose sum has the given rms (per the vector's length)."""
    amplitude = rng.standard_normal((3, 3))
    return amplitude * rms / np.sqrt(0.5 * np.sum(amplitude**2)) if rms > 0 else np.zeros((3, 3))


def _move(t0, t1, attitude, position, turn, shift, peak_rate, rng) -> tuple[Piece, float]:
    """A move whose wobble is scaled so that its peak rate is ``peak_rate`` (or the turn's own, if larger)."""
    directions = [rng.standard_normal(3) for _ in range(3)]
    directions = [d / np.linalg.norm(d) * w for d, w in zip(directions, (1.0, 0.5, 0.25))]
    shift_wobble = tuple(rng.standard_normal(3) * 0.1 * max(np.linalg.norm(shift), 0.02) for _ in range(2))
    tau = np.linspace(0.0, 1.0, 801)

    def peak(scale):
        r = np.outer(_min_jerk(tau), turn) + _wobble(tau, [scale * d for d in directions])
        return float(np.max(np.linalg.norm(np.diff(r, axis=0), axis=1))) * 800.0 / (t1 - t0)

    low, high = 0.0, 1.0
    if peak(0.0) < peak_rate:
        while peak(high) < peak_rate and high < 1e3:
            high *= 2.0
        for _ in range(40):
            mid = 0.5 * (low + high)
            low, high = (mid, high) if peak(mid) < peak_rate else (low, mid)
    scale = high if peak(0.0) < peak_rate else 0.0
    piece = Piece(t0, t1, attitude, position, turn=turn, turn_wobble=tuple(scale * d for d in directions),
                  shift=shift, shift_wobble=shift_wobble)
    return piece, peak(scale)


def hand_increments(motion: HandMotion, n_samples: int, dt: float, jitter: float, rng: np.random.Generator):
    """True ``(dtheta, dv)`` per sample interval (the true instants scattered by ``jitter`` sample intervals rms)."""
    edges = np.arange(n_samples + 1) * dt
    if jitter > 0.0:
        edges[1:-1] += rng.standard_normal(n_samples - 1) * jitter * dt
    dtheta = np.empty((n_samples, 3))
    dv = np.empty((n_samples, 3))
    chunk = 20000
    for first in range(0, n_samples, chunk):
        stop = min(first + chunk, n_samples)
        a, b = edges[first:stop], edges[first + 1:stop + 1]
        nodes = a[:, None] + (b - a)[:, None] * (1.0 + _GAUSS_X[None, :]) / 2.0
        weights = (b - a)[:, None] * _GAUSS_W[None, :] / 2.0
        _, rate, force = motion._state(nodes.ravel())
        dtheta[first:first + len(a)] = np.einsum("nj,njk->nk", weights, rate.reshape(nodes.shape + (3,)))
        dv[first:first + len(a)] = np.einsum("nj,njk->nk", weights, force.reshape(nodes.shape + (3,)))
    return dtheta, dv
