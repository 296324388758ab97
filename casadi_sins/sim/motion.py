"""The motion of a unit on a turntable: pieces of still and turning, deviations from nominal, base sway.

One description of motion serves the simulator, the schedule design and the rotation schemes of the
modulation study (:mod:`studies.modulation.schemes`): a :class:`MotionPiece` holds the attitude still or
turns it about an axis fixed in the body, ``C(t) = C_0 R(u, alpha(t))``, with a rate profile (sinusoidal,
minimum-jerk, versine, or constant as a rotation scheme's turns).

The unit sits at the centre of a turntable fixed to the Earth.  In a static segment its attitude
``C_b^n`` is constant; in a rotation it turns about an axis fixed in the body with a sinusoidal rate
profile; between groups it is handled to the
next start position: one turn with the rotations' rate profile (``[timing] handling = "turn"``, the
default), or a tumble by hand (``"minimum-jerk"``): slerps through :data:`HANDLING_WAYPOINTS` random
attitudes, each leg with the minimum-jerk time law ``10 tau^3 - 15 tau^4 + 6 tau^5`` and a peak rate
of :data:`HANDLING_PEAK_DEG_S` (higher when the legs need it to fit the gap), pauses at the waypoints
filling the rest of the gap.  A swaying base turns the whole unit about its centre; a base with
linear motion (a ship's deck: heave, surge) carries it along a bounded path.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.orientation import orientation_to_dcm, parse_axis
from ..core.rotations import rotation_matrices, rotation_matrix, rotation_vector
from ..core.units import DEG
from ..data.problem import Problem

#: Hand tumbles between groups (``handling = "minimum-jerk"``): intermediate attitudes, the angle of each
#: leg to them (deg, uniform) and the peak rate of every leg (deg/s; 1.875 x the leg's mean rate).
HANDLING_WAYPOINTS = 3
HANDLING_LEG_DEG = (60.0, 150.0)
HANDLING_PEAK_DEG_S = 15.0


#: The rate profiles of a turn: the rate over the turn's fraction ``tau`` goes as ``sin(pi tau)``,
#: ``tau^2 (1 - tau)^2``, ``1 - cos(2 pi tau)`` or is constant.
PROFILES = ("half-sine", "minimum-jerk", "versine", "constant")


@dataclasses.dataclass(frozen=True)
class MotionPiece:
    """One piece of the trajectory: attitude ``C0 R(axis, angle(t))`` over ``[t0, t1]`` (still: ``axis`` None).

    Attributes
    ----------
    t0, t1 : float
        Start and end, s.
    attitude : ndarray (3, 3)
        ``C_b^n`` at ``t0``.
    axis : ndarray (3,) or None
        Unit turn axis in the body; ``None`` for a still piece.
    angle : float
        Signed angle turned over the piece about ``axis``, rad.
    profile : str
        The rate profile (:data:`PROFILES`).
    """

    t0: float
    t1: float
    attitude: np.ndarray  # C_b^n at t0
    axis: np.ndarray | None = None  # unit vector in body; None: static
    angle: float = 0.0  # total angle turned over the piece, rad
    profile: str = "half-sine"

    @property
    def duration(self) -> float:
        """Length of the piece, s."""
        return self.t1 - self.t0

    def angle_at(self, t: np.ndarray) -> np.ndarray:
        """Angle turned since ``t0`` (the integral of the rate profile)."""
        tau = np.clip((np.asarray(t) - self.t0) / (self.t1 - self.t0), 0.0, 1.0)
        if self.profile == "constant":
            return self.angle * tau
        if self.profile == "half-sine":  # rate ~ sin(pi tau)
            return self.angle * 0.5 * (1.0 - np.cos(np.pi * tau))
        if self.profile == "minimum-jerk":  # rate ~ tau^2 (1 - tau)^2
            return self.angle * tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
        return self.angle * (tau - np.sin(2.0 * np.pi * tau) / (2.0 * np.pi))  # versine: rate ~ 1 - cos

    def rate_at(self, t: np.ndarray) -> np.ndarray:
        """Rate of turn (rad/s) about the axis: the derivative of :meth:`angle_at`."""
        span = self.t1 - self.t0
        tau = (np.asarray(t) - self.t0) / span
        inside = (tau >= 0.0) & (tau <= 1.0)
        if self.profile == "constant":
            rate = np.full(np.shape(tau), self.angle / span)
        elif self.profile == "half-sine":
            rate = self.angle * 0.5 * np.pi / span * np.sin(np.pi * tau)
        elif self.profile == "minimum-jerk":
            rate = self.angle / span * 30.0 * tau**2 * (1.0 - tau) ** 2
        else:
            rate = self.angle / span * (1.0 - np.cos(2.0 * np.pi * tau))
        return np.where(inside, rate, 0.0)

    def attitude_at(self, t: np.ndarray) -> np.ndarray:
        """``C_b^n`` at times ``t``, shape ``t.shape + (3, 3)``."""
        if self.axis is None:
            return np.broadcast_to(self.attitude, np.shape(t) + (3, 3))
        return self.attitude @ rotation_matrix(self.axis, self.angle_at(t))

    def turn_rate(self, t: np.ndarray) -> np.ndarray:
        """The turntable's rate in the body (rad/s) at times ``t``, shape ``t.shape + (3,)`` (zero when still)."""
        if self.axis is None:
            return np.zeros(np.shape(t) + (3,))
        return self.rate_at(t)[..., None] * self.axis

    @property
    def end_attitude(self) -> np.ndarray:
        """``C_b^n`` at ``t1``."""
        return self.attitude_at(np.array(self.t1))

    def part(self, t0: float, t1: float) -> "MotionPiece":
        """The same motion over ``[t0, t1]`` inside the piece (a still or constant-rate piece only: any other
        profile would change its shape)."""
        if self.axis is not None and self.profile != "constant":
            raise ValueError(f"a {self.profile} turn has no part of the same profile")
        attitude = self.attitude if t0 == self.t0 else self.attitude_at(np.array(t0))
        angle = 0.0 if self.axis is None else self.angle * (t1 - t0) / (self.t1 - self.t0)
        return dataclasses.replace(self, t0=t0, t1=t1, attitude=attitude, angle=angle)

    def shifted(self, offset: float) -> "MotionPiece":
        """The same piece ``offset`` seconds later."""
        return dataclasses.replace(self, t0=self.t0 + offset, t1=self.t1 + offset)


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
            pieces += handling_pieces(pieces[-1].t1, segs[0].start, attitude, start, problem.timing, rng)
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


def _slerp_piece(t0: float, t1: float, attitude: np.ndarray, target: np.ndarray, profile: str) -> MotionPiece:
    """The turn from ``attitude`` to ``target`` about one body axis (a slerp) over ``[t0, t1]``."""
    turn = rotation_vector(attitude.T @ target)
    angle = float(np.linalg.norm(turn))
    return MotionPiece(t0, t1, attitude, turn / angle if angle > 0 else None, angle, profile)


def handling_pieces(t0: float, t1: float, attitude: np.ndarray, target: np.ndarray, timing,
                    rng: np.random.Generator) -> list[MotionPiece]:
    """The handling between two groups over ``[t0, t1]``: one turn with the rate profile, or a hand tumble
    (``timing.handling == "minimum-jerk"``, see the module docstring; draws from ``rng`` only then)."""
    if timing.handling != "minimum-jerk":
        return [_slerp_piece(t0, t1, attitude, target, timing.rate_profile)]
    waypoints = [attitude]
    for _ in range(HANDLING_WAYPOINTS):
        axis = rng.standard_normal(3)
        angle = rng.uniform(*HANDLING_LEG_DEG) * DEG
        waypoints.append(waypoints[-1] @ rotation_matrix(axis, angle))
    waypoints.append(target)
    angles = np.array([np.linalg.norm(rotation_vector(a.T @ b)) for a, b in zip(waypoints[:-1], waypoints[1:])])
    span = t1 - t0
    durations = 1.875 * angles / (HANDLING_PEAK_DEG_S * DEG)  # peak rate of a minimum-jerk leg: 1.875 angle / T
    if durations.sum() > span:  # faster legs to fit the gap
        durations *= span / durations.sum()
    pause = (span - durations.sum()) / HANDLING_WAYPOINTS  # at each intermediate waypoint
    pieces = []
    t = t0
    for k, (a, b) in enumerate(zip(waypoints[:-1], waypoints[1:])):
        end = t1 if k == len(durations) - 1 else t + durations[k]
        pieces.append(_slerp_piece(t, end, a, b, "minimum-jerk"))
        if k < HANDLING_WAYPOINTS and pause > 0:
            pieces.append(MotionPiece(end, end + pause, b))
        t = end + max(pause, 0.0)
    return pieces


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


@dataclasses.dataclass(frozen=True)
class Translation:
    """Linear motion of the base (heave, surge): the unit's centre at ``p(t)`` (ENU, m) from its mean place.

    ``p(t)`` is a sum of sinusoids per axis, bounded and without drift; the specific force gains the
    base's acceleration and its Coriolis term, ``f^n = p'' + 2 w_ie x p' + g^n``.
    """

    amplitude: np.ndarray  # (3, M) m
    omega: np.ndarray  # (3, M) rad/s
    phase: np.ndarray  # (3, M) rad

    @classmethod
    def draw(cls, amplitude_m: tuple[float, float], period_s: tuple[float, float], components: int, axes: str,
             peak_mps2: float, rng: np.random.Generator) -> "Translation":
        """Random sinusoids on the ENU ``axes`` (letters of "ENU"): amplitudes uniform, periods log-uniform,
        random phases; each axis scaled down to a peak acceleration of ``peak_mps2`` when it exceeds it
        (0: no limit)."""
        amp = rng.uniform(amplitude_m[0], amplitude_m[1], size=(3, components))
        period = np.exp(rng.uniform(np.log(period_s[0]), np.log(period_s[1]), size=(3, components)))
        phase = rng.uniform(0.0, 2.0 * np.pi, size=(3, components))
        omega = 2.0 * np.pi / period
        amp *= np.array(["ENU"[k] in axes for k in range(3)], dtype=float)[:, None]
        if peak_mps2 > 0.0:
            peak = np.sum(amp * omega**2, axis=1, keepdims=True)
            amp *= np.minimum(1.0, peak_mps2 / np.maximum(peak, 1e-300))
        return cls(amp, omega, phase)

    def _terms(self, t: np.ndarray, derivative: int) -> np.ndarray:
        arg = np.asarray(t)[..., None, None] * self.omega + self.phase + derivative * np.pi / 2.0
        return np.sum(self.amplitude * self.omega**derivative * np.sin(arg), axis=-1)

    def position(self, t: np.ndarray) -> np.ndarray:
        """``p(t)``, shape ``t.shape + (3,)``."""
        return self._terms(t, 0)

    def velocity(self, t: np.ndarray) -> np.ndarray:
        """``p'(t)``, shape ``t.shape + (3,)``."""
        return self._terms(t, 1)

    def acceleration(self, t: np.ndarray) -> np.ndarray:
        """``p''(t)``, shape ``t.shape + (3,)``."""
        return self._terms(t, 2)

    def force(self, t: np.ndarray, earth_rate: np.ndarray) -> np.ndarray:
        """What the motion adds to the specific force in n: ``p'' + 2 w_ie x p'``."""
        return self.acceleration(t) + 2.0 * np.cross(earth_rate, self.velocity(t))


def kinematics_function(pieces: list[MotionPiece], earth_rate: np.ndarray, gravity: float, sway: Sway | None = None,
                        translation: Translation | None = None):
    """``kinematics(t) -> (C_b^n, w_b, w_dot_b, f_b)`` at any times (shape ``t.shape + (3, 3)`` / ``(3,)``).

    ``w_b`` is the body's inertial rate (table, sway and Earth rate), ``f_b`` the specific force at the
    unit's centre (the base turns it about its centre and carries it along ``translation``), ``w_dot_b``
    by a central difference of 10 us.
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
        if translation is not None:
            force = force + np.einsum("nji,nj->ni", attitude, translation.force(flat, earth_rate))
        shape = t.shape
        return (attitude.reshape(shape + (3, 3)), rate.reshape(shape + (3,)), rate_dot.reshape(shape + (3,)),
                force.reshape(shape + (3,)))

    return kinematics
