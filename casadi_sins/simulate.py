"""Simulation of a problem: exact kinematics of the schedule -> raw pulses.

The unit sits at the centre of a turntable fixed to the Earth.  In a static
segment its attitude ``C_b^n`` is constant; in a rotation it turns about an
axis fixed in the body, ``C(t) = C_0 R(u, alpha(t))``, with a sinusoidal rate
profile.  The true increments of a sample interval are the exact integrals

    dtheta = u (alpha(b) - alpha(a)) + int_a^b C(t)^T w_ie^n dt
    dv     = int_a^b C(t)^T (0, 0, g) dt

evaluated with 6-point Gauss-Legendre quadrature on every piece of the
interval between motion breakpoints (error below 1e-18 rad per sample; the
integrands are analytic inside a piece).  White noise is added to the true
increments and the output model (eq. 1, :func:`parameters.output_model`)
turns them into pulses.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from . import frames
from . import parameters as P
from .problem import Problem
from .recording import Recording, write_recording
from .units import ARCSEC, DEG, DEG_PER_H, UG

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(6)


@dataclasses.dataclass(frozen=True)
class Motion:
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
        if self.axis is None:
            return np.broadcast_to(self.attitude, np.shape(t) + (3, 3))
        return self.attitude @ frames.rotation_matrix(self.axis, self.angle_at(t))

    @property
    def end_attitude(self) -> np.ndarray:
        return self.attitude_at(np.array(self.t1))


@dataclasses.dataclass
class Simulation:
    """A simulated recording with everything that is true about it."""

    recording: Recording
    truth: P.ParameterSet
    start_attitudes: dict[int, np.ndarray]  # group -> true C_b^n at the start of the group
    static_attitudes: list[np.ndarray]  # true C_b^n in each static segment, in order
    rate_factors: list[float]
    seed: int | None
    sway: "Sway | None" = None


def rotation_vector_robust(dcm: np.ndarray) -> np.ndarray:
    """Rotation vector of any rotation matrix (via the quaternion; stable near 180 deg)."""
    from .strapdown import dcm_to_quat

    q = dcm_to_quat(dcm)
    norm = np.linalg.norm(q[1:])
    if norm < 1e-15:
        return np.zeros(3)
    return 2.0 * math.atan2(norm, q[0]) * q[1:] / norm


def plan_motion(problem: Problem, rng: np.random.Generator):
    """Draw the deviations and lay out the trajectory as :class:`Motion` pieces."""
    dev = problem.deviations
    pieces: list[Motion] = []
    starts: dict[int, np.ndarray] = {}
    statics: list[np.ndarray] = []
    factors: list[float] = []
    attitude = None
    segments = problem.segments()
    for group in sorted({s.group for s in segments}):
        segs = [s for s in segments if s.group == group]
        nominal = frames.orientation_to_dcm(segs[0].orientation)
        offset = rng.choice([-1.0, 1.0], size=3) * dev.start_attitude_deg * DEG
        start = frames.small_rotation(offset) @ nominal
        if attitude is not None and pieces[-1].t1 < segs[0].start:  # handling between groups
            turn = rotation_vector_robust(attitude.T @ start)
            angle = float(np.linalg.norm(turn))
            pieces.append(Motion(pieces[-1].t1, segs[0].start, attitude,
                                 turn / angle if angle > 0 else None, angle, problem.timing.rate_profile))
        attitude = start
        starts[group] = start
        for seg in segs:
            if seg.is_static:
                pieces.append(Motion(seg.start, seg.end, attitude))
                statics.append(attitude)
                continue
            axis = frames.parse_axis(seg.axis)
            rate_axis = axis + dev.cross_axis_rate * (1.0 - np.abs(axis))
            factor = 1.0 + rng.uniform(-dev.rotation_rate_factor, dev.rotation_rate_factor)
            factors.append(factor)
            angle = float(np.linalg.norm(rate_axis)) * factor * seg.angle_deg * DEG
            piece = Motion(seg.start, seg.end, attitude, rate_axis / np.linalg.norm(rate_axis), angle,
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
        amp = rng.uniform(amplitude_rad[0], amplitude_rad[1], size=(3, components))
        period = np.exp(rng.uniform(np.log(period_s[0]), np.log(period_s[1]), size=(3, components)))
        return cls(amp, 2.0 * np.pi / period, rng.uniform(0.0, 2.0 * np.pi, size=(3, components)))

    def angle(self, t: np.ndarray) -> np.ndarray:
        """``s(t)``, shape ``t.shape + (3,)``."""
        arg = np.asarray(t)[..., None, None] * self.omega + self.phase
        return np.sum(self.amplitude * np.sin(arg), axis=-1)

    def angle_rate(self, t: np.ndarray) -> np.ndarray:
        arg = np.asarray(t)[..., None, None] * self.omega + self.phase
        return np.sum(self.amplitude * self.omega * np.cos(arg), axis=-1)

    def attitude(self, t: np.ndarray) -> np.ndarray:
        """``exp([s x])``, shape ``t.shape + (3, 3)``."""
        return frames.rotation_matrices(self.angle(t))

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


#: Sample pieces integrated at once by quadrature (bounds the memory of long recordings).
_QUADRATURE_CHUNK = 20000


def true_increments(pieces: list[Motion], n_samples: int, dt: float, earth_rate: np.ndarray, gravity: float,
                    sway: Sway | None = None):
    """Exact true ``(dtheta, dv)`` per sample interval ``[(k) dt, (k+1) dt]``, k = 0..n-1.

    Without sway a static piece is integrated in closed form; everything else by 6-point
    Gauss-Legendre quadrature on each sample's part of the piece (the integrands are analytic
    there): ``dtheta = int C^T (w_ie + w_sway) dt + u (alpha(b) - alpha(a))``, ``dv = int C^T g^n dt``.
    """
    edges = np.arange(n_samples + 1) * dt
    dtheta = np.zeros((n_samples, 3))
    dv = np.zeros((n_samples, 3))
    references = np.column_stack([earth_rate, [0.0, 0.0, gravity]])  # w_ie^n and f^n at rest
    eps = 1e-9 * dt
    for piece in pieces:
        inner = edges[(edges > piece.t0 + eps) & (edges < piece.t1 - eps)]
        points = np.concatenate([[piece.t0], inner, [min(piece.t1, edges[-1])]])
        a_all, b_all = points[:-1], points[1:]
        keep = b_all > a_all + eps
        a_all, b_all = a_all[keep], b_all[keep]
        for first in range(0, len(a_all), _QUADRATURE_CHUNK):
            a, b = a_all[first:first + _QUADRATURE_CHUNK], b_all[first:first + _QUADRATURE_CHUNK]
            sample = np.clip(np.searchsorted(edges, 0.5 * (a + b)) - 1, 0, n_samples - 1)
            if piece.axis is None and sway is None:
                integral = (b - a)[:, None, None] * (piece.attitude.T @ references)[None]
            else:
                nodes = a[:, None] + (b - a)[:, None] * (1.0 + _GAUSS_X[None, :]) / 2.0
                weights = (b - a)[:, None] * _GAUSS_W[None, :] / 2.0
                c_nodes = piece.attitude_at(nodes)  # (M, J, 3, 3)
                if sway is None:
                    values = np.swapaxes(c_nodes, -1, -2) @ references  # (M, J, 3, 2)
                else:
                    c_nodes = sway.attitude(nodes) @ c_nodes
                    rate = earth_rate + sway.rate(nodes)  # (M, J, 3)
                    gravity_n = np.broadcast_to([0.0, 0.0, gravity], rate.shape)
                    values = np.swapaxes(c_nodes, -1, -2) @ np.stack([rate, gravity_n], axis=-1)
                integral = np.einsum("mj,mjkl->mkl", weights, values)
            turned = (np.zeros((len(a), 3)) if piece.axis is None
                      else np.outer(piece.angle_at(b) - piece.angle_at(a), piece.axis))
            np.add.at(dtheta, sample, integral[:, :, 0] + turned)
            np.add.at(dv, sample, integral[:, :, 1])
    return dtheta, dv


def kinematics_function(pieces: list[Motion], earth_rate: np.ndarray, gravity: float, sway: Sway | None = None):
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


def accelerometer_extras(pieces, problem: Problem, n_samples: int, dt: float, sway: Sway | None):
    """The extra terms of the truth in every accelerometer sample: ``(dv_f, dv_lever, q2)``
    (:func:`extended.sensed_extras`, exact physics by quadrature, in chunks)."""
    from .extended import sensed_extras

    kinematics = kinematics_function(pieces, problem.site.earth_rate, problem.site.g, sway)
    parts = []
    for first in range(0, n_samples, _QUADRATURE_CHUNK):
        t0 = np.arange(first, min(first + _QUADRATURE_CHUNK, n_samples)) * dt
        parts.append(sensed_extras(kinematics, t0, t0 + dt, problem.truth))
    return tuple(np.vstack([p[k] for p in parts]) for k in range(3))


def gauss_markov(n: int, dt: float, sigma: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """A first-order Gauss-Markov process per axis, (n, 3), stationary from the start (exact AR(1))."""
    if sigma == 0.0:
        return np.zeros((n, 3))
    phi = np.exp(-dt / tau)
    drive = rng.standard_normal((n, 3)) * sigma * np.sqrt(1.0 - phi**2)
    drive[0] = rng.standard_normal(3) * sigma
    from scipy.signal import lfilter

    return lfilter([1.0], [1.0, -phi], drive, axis=0)


def quantize(pulses: np.ndarray) -> np.ndarray:
    """Integer pulses with the remainder carried to the next sample (no drift of the sum)."""
    counts = np.round(np.cumsum(pulses, axis=0))
    return np.diff(counts, axis=0, prepend=np.zeros((1, pulses.shape[1])))


def simulate(problem: Problem, seed: int | None = 0, noise: bool = True, name: str | None = None) -> Simulation:
    """Simulate the problem's experiment.

    Parameters
    ----------
    problem : Problem
    seed : int or None
        Seed of every random draw (deviations and noise).
    noise : bool
        ``False`` leaves out the sensor noise (not the deviations), for checks.
    """
    rng = np.random.default_rng(seed)
    pieces, starts, statics, factors = plan_motion(problem, rng)
    dev = problem.deviations
    # drawn after the motion, so that adding sway leaves the other draws of a seed as they were
    sway = (Sway.draw(tuple(a * ARCSEC for a in dev.sway_amplitude_arcsec), dev.sway_period_s,
                      dev.sway_components, rng) if dev.sways else None)
    dt = 1.0 / problem.rate_hz
    duration = pieces[-1].t1
    n_samples = int(round(duration * problem.rate_hz))
    g = problem.site.g
    dtheta, dv = true_increments(pieces, n_samples, dt, problem.site.earth_rate, g, sway)
    truth = problem.truth
    extra_output = np.zeros_like(dv)  # what the extras add to K_a dv in the output model
    if any(truth[n] != 0.0 for n in truth.names[P.N_PARAMS:]):
        dv, lever, q2 = accelerometer_extras(pieces, problem, n_samples, dt, sway)
        k2 = np.array([truth[f"accel_quadratic_{a}"] if "accel_quadratic_x" in truth.names else 0.0 for a in "xyz"])
        extra_output = lever + k2 * q2
    if noise:
        gyro_white = np.hypot(dev.gyro_noise_deg_h * DEG_PER_H * dt, dev.gyro_arw_deg_rth * DEG / 60.0 * np.sqrt(dt))
        accel_white = np.hypot(dev.accel_noise_ug * UG * dt, dev.accel_vrw_ug_rthz * UG * np.sqrt(dt))
        dtheta = dtheta + rng.standard_normal(dtheta.shape) * gyro_white
        dv = dv + rng.standard_normal(dv.shape) * accel_white
        dtheta += dt * gauss_markov(n_samples, dt, dev.gyro_bias_instability_deg_h * DEG_PER_H,
                                    dev.gyro_bias_tau_s, rng)
        dv += dt * gauss_markov(n_samples, dt, dev.accel_bias_instability_ug * UG, dev.accel_bias_tau_s, rng)
    gyro, accel = P.output_model(dtheta, dv, truth.core, dt)
    accel = accel + extra_output / truth.core[P.ACCEL_SCALE]
    if problem.deviations.quantize:
        gyro, accel = quantize(gyro), quantize(accel)
    time = np.round(np.arange(1, n_samples + 1) * dt, 9)
    rec_name = name or (f"{problem.name}-seed{seed}" if seed is not None else problem.name)
    recording = Recording(name=rec_name, site=problem.site, rate_hz=problem.rate_hz, segments=problem.segments(),
                          time=time, gyro=gyro, accel=accel)
    if sway is not None:  # the true start of a group on a swaying base
        first = {seg.group: seg.start for seg in reversed(recording.segments)}
        starts = {g: sway.attitude(np.array(first[g])) @ c for g, c in starts.items()}
    return Simulation(recording, problem.truth, starts, statics, factors, seed, sway)


def write_simulation(sim: Simulation, out_dir: str | Path) -> Path:
    """Write ``NAME.toml``, ``NAME.csv`` and ``NAME.truth.csv`` into ``out_dir``; returns the TOML path."""
    out_dir = Path(out_dir)
    toml_path = write_recording(sim.recording, out_dir / f"{sim.recording.name}.toml")
    P.write_table(out_dir / f"{sim.recording.name}.truth.csv", sim.truth, as_truth=True)
    return toml_path
