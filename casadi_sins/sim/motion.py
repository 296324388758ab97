"""The motion of a simulated experiment: turntable pieces, deviations from nominal, base sway.

The unit sits at the centre of a turntable fixed to the Earth.  In a static segment its attitude
``C_b^n`` is constant; in a rotation it turns about an axis fixed in the body,
``C(t) = C_0 R(u, alpha(t))``, with a sinusoidal rate profile; between groups it is handled to the
next start position.  A swaying base turns the whole unit about its centre.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.orientation import orientation_to_dcm, parse_axis
from ..core.rotations import rotation_matrices, rotation_matrix, rotation_vector
from ..core.units import DEG
from ..data.problem import Problem

@dataclasses.dataclass(frozen=True)
class MotionPiece:
    """One piece of the trajectory: attitude ``C0 R(axis, angle(t))`` over ``[t0, t1]``."""

    t0: float
    t1: float
    attitude: np.ndarray  # C_b^n at t0
    axis: np.ndarray | None = None  # unit vector in body; None: static
    angle: float = 0.0  # total angle turned over the piece, rad
    profile: str = "half-sine"

    def angle_at(self, t: np.ndarray) -> np.ndarray:
        """Angle turned since ``t0`` (the integral of the rate profile)."""
        tau = np.clip((np.asarray(t) - self.t0) / (self.t1 - self.t0), 0.0, 1.0)
        if self.profile == "half-sine":  # rate ~ sin(pi tau)
            return self.angle * 0.5 * (1.0 - np.cos(np.pi * tau))
        return self.angle * (tau - np.sin(2.0 * np.pi * tau) / (2.0 * np.pi))  # versine: rate ~ 1 - cos

    def rate_at(self, t: np.ndarray) -> np.ndarray:
        """Rate of turn (rad/s) about the axis: the derivative of :meth:`angle_at`."""
        span = self.t1 - self.t0
        tau = (np.asarray(t) - self.t0) / span
        inside = (tau >= 0.0) & (tau <= 1.0)
        if self.profile == "half-sine":
            rate = self.angle * 0.5 * np.pi / span * np.sin(np.pi * tau)
        else:
            rate = self.angle / span * (1.0 - np.cos(2.0 * np.pi * tau))
        return np.where(inside, rate, 0.0)

    def attitude_at(self, t: np.ndarray) -> np.ndarray:
        """``C_b^n`` at times ``t``, shape ``t.shape + (3, 3)``."""
        if self.axis is None:
            return np.broadcast_to(self.attitude, np.shape(t) + (3, 3))
        return self.attitude @ rotation_matrix(self.axis, self.angle_at(t))

    @property
    def end_attitude(self) -> np.ndarray:
        """``C_b^n`` at ``t1``."""
        return self.attitude_at(np.array(self.t1))


def plan_motion(problem: Problem, rng: np.random.Generator):
    """Draw the deviations and lay out the trajectory as :class:`MotionPiece` pieces."""
    dev = problem.deviations
    pieces: list[MotionPiece] = []
    starts: dict[int, np.ndarray] = {}
    statics: list[np.ndarray] = []
    factors: list[float] = []
    attitude = None
    segments = problem.segments()
    for group in sorted({s.group for s in segments}):
        segs = [s for s in segments if s.group == group]
        nominal = orientation_to_dcm(segs[0].orientation)
        offset = rng.choice([-1.0, 1.0], size=3) * dev.start_attitude_deg * DEG
        start = rotation_matrices(offset) @ nominal
        if attitude is not None and pieces[-1].t1 < segs[0].start:  # handling between groups
            turn = rotation_vector(attitude.T @ start)
            angle = float(np.linalg.norm(turn))
            pieces.append(MotionPiece(pieces[-1].t1, segs[0].start, attitude,
                                 turn / angle if angle > 0 else None, angle, problem.timing.rate_profile))
        attitude = start
        starts[group] = start
        for seg in segs:
            if seg.is_static:
                pieces.append(MotionPiece(seg.start, seg.end, attitude))
                statics.append(attitude)
                continue
            axis = parse_axis(seg.axis)
            rate_axis = axis + dev.cross_axis_rate * (1.0 - np.abs(axis))
            factor = 1.0 + rng.uniform(-dev.rotation_rate_factor, dev.rotation_rate_factor)
            factors.append(factor)
            angle = float(np.linalg.norm(rate_axis)) * factor * seg.angle_deg * DEG
            piece = MotionPiece(seg.start, seg.end, attitude, rate_axis / np.linalg.norm(rate_axis), angle,
                           problem.timing.rate_profile)
            pieces.append(piece)
            attitude = piece.end_attitude
    return pieces, starts, statics, factors


@dataclasses.dataclass(frozen=True)
class Sway:
    """Rotation of the whole base about the unit's centre: ``C_b^n(t) = exp([s(t) x]) C_table(t)``.

    ``s(t)`` (ENU rotation vector, rad) is a sum of sinusoids per axis; the base turns the unit
    about its centre, so the specific force stays gravity and only the rate changes.
    """

    amplitude: np.ndarray  # (3, M) rad
    omega: np.ndarray  # (3, M) rad/s
    phase: np.ndarray  # (3, M) rad

    @classmethod
    def draw(cls, amplitude_rad: tuple[float, float], period_s: tuple[float, float], components: int,
             rng: np.random.Generator) -> "Sway":
        """Random sinusoids: amplitudes uniform, periods log-uniform in the ranges, random phases."""
        amp = rng.uniform(amplitude_rad[0], amplitude_rad[1], size=(3, components))
        period = np.exp(rng.uniform(np.log(period_s[0]), np.log(period_s[1]), size=(3, components)))
        return cls(amp, 2.0 * np.pi / period, rng.uniform(0.0, 2.0 * np.pi, size=(3, components)))

    def angle(self, t: np.ndarray) -> np.ndarray:
        """``s(t)``, shape ``t.shape + (3,)``."""
        arg = np.asarray(t)[..., None, None] * self.omega + self.phase
        return np.sum(self.amplitude * np.sin(arg), axis=-1)

    def angle_rate(self, t: np.ndarray) -> np.ndarray:
        """``s'(t)``, shape ``t.shape + (3,)``."""
        arg = np.asarray(t)[..., None, None] * self.omega + self.phase
        return np.sum(self.amplitude * self.omega * np.cos(arg), axis=-1)

    def attitude(self, t: np.ndarray) -> np.ndarray:
        """``exp([s x])``, shape ``t.shape + (3, 3)``."""
        return rotation_matrices(self.angle(t))

    def rate(self, t: np.ndarray) -> np.ndarray:
        """Angular rate of the base in n (rad/s): ``J_l(s) s_dot`` (left Jacobian of SO(3))."""
        s, s_dot = self.angle(t), self.angle_rate(t)
        theta2 = np.sum(s * s, axis=-1)[..., None]
        small = theta2 < 1e-12
        theta = np.sqrt(np.where(small, 1.0, theta2))
        a = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(theta)) / np.where(small, 1.0, theta2))
        b = np.where(small, 1.0 / 6.0 - theta2 / 120.0, (theta - np.sin(theta)) / (theta * np.where(small, 1.0, theta2)))
        cross = np.cross(s, s_dot)
        return s_dot + a * cross + b * np.cross(s, cross)


def kinematics_function(pieces: list[MotionPiece], earth_rate: np.ndarray, gravity: float, sway: Sway | None = None):
    """``kinematics(t) -> (C_b^n, w_b, w_dot_b, f_b)`` at any times (shape ``t.shape + (3, 3)`` / ``(3,)``).

    ``w_b`` is the body's inertial rate (table, sway and Earth rate), ``f_b`` the specific force at the
    unit's centre (the base turns it about its centre), ``w_dot_b`` by a central difference of 10 us.
    """
    starts = np.array([p.t0 for p in pieces])

    def attitude_and_rate(flat):
        index = np.clip(np.searchsorted(starts, flat, side="right") - 1, 0, len(pieces) - 1)
        attitude = np.empty(flat.shape + (3, 3))
        table_rate = np.zeros(flat.shape + (3,))
        for k in np.unique(index):
            sel = index == k
            piece = pieces[k]
            attitude[sel] = piece.attitude_at(flat[sel])
            if piece.axis is not None:
                table_rate[sel] = np.outer(piece.rate_at(flat[sel]), piece.axis)
        inertial = np.broadcast_to(earth_rate, flat.shape + (3,))
        if sway is not None:
            attitude = sway.attitude(flat) @ attitude
            inertial = inertial + sway.rate(flat)
        rate = np.einsum("nji,nj->ni", attitude, inertial) + table_rate
        return attitude, rate

    def kinematics(t):
        t = np.asarray(t, dtype=float)
        flat = t.ravel()
        attitude, rate = attitude_and_rate(flat)
        step = 1e-5
        rate_dot = (attitude_and_rate(flat + step)[1] - attitude_and_rate(flat - step)[1]) / (2.0 * step)
        force = attitude[:, 2, :] * gravity  # C^T (0, 0, g)
        shape = t.shape
        return (attitude.reshape(shape + (3, 3)), rate.reshape(shape + (3,)), rate_dot.reshape(shape + (3,)),
                force.reshape(shape + (3,)))

    return kinematics
