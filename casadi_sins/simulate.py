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
from .units import DEG, DEG_PER_H, UG

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


def true_increments(pieces: list[Motion], n_samples: int, dt: float, earth_rate: np.ndarray, gravity: float):
    """Exact true ``(dtheta, dv)`` per sample interval ``[(k) dt, (k+1) dt]``, k = 0..n-1."""
    edges = np.arange(n_samples + 1) * dt
    dtheta = np.zeros((n_samples, 3))
    dv = np.zeros((n_samples, 3))
    references = np.column_stack([earth_rate, [0.0, 0.0, gravity]])  # w_ie^n and f^n at rest
    eps = 1e-9 * dt
    for piece in pieces:
        inner = edges[(edges > piece.t0 + eps) & (edges < piece.t1 - eps)]
        points = np.concatenate([[piece.t0], inner, [min(piece.t1, edges[-1])]])
        a, b = points[:-1], points[1:]
        keep = b > a + eps
        a, b = a[keep], b[keep]
        sample = np.clip(np.searchsorted(edges, 0.5 * (a + b)) - 1, 0, n_samples - 1)
        if piece.axis is None:
            integral = (b - a)[:, None, None] * (piece.attitude.T @ references)[None]
            turned = np.zeros((len(a), 3))
        else:
            nodes = a[:, None] + (b - a)[:, None] * (1.0 + _GAUSS_X[None, :]) / 2.0
            weights = (b - a)[:, None] * _GAUSS_W[None, :] / 2.0
            c_nodes = piece.attitude_at(nodes)  # (M, J, 3, 3)
            values = np.swapaxes(c_nodes, -1, -2) @ references  # (M, J, 3, 2)
            integral = np.einsum("mj,mjkl->mkl", weights, values)
            turned = np.outer(piece.angle_at(b) - piece.angle_at(a), piece.axis)
        np.add.at(dtheta, sample, integral[:, :, 0] + turned)
        np.add.at(dv, sample, integral[:, :, 1])
    return dtheta, dv


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
    dt = 1.0 / problem.rate_hz
    duration = pieces[-1].t1
    n_samples = int(round(duration * problem.rate_hz))
    g = problem.site.g
    dtheta, dv = true_increments(pieces, n_samples, dt, problem.site.earth_rate, g)
    if noise:
        dev = problem.deviations
        dtheta = dtheta + rng.standard_normal(dtheta.shape) * dev.gyro_noise_deg_h * DEG_PER_H * dt
        dv = dv + rng.standard_normal(dv.shape) * dev.accel_noise_ug * UG * dt
    gyro, accel = P.output_model(dtheta, dv, problem.truth.values, dt)
    if problem.deviations.quantize:
        gyro, accel = quantize(gyro), quantize(accel)
    time = np.round(np.arange(1, n_samples + 1) * dt, 9)
    rec_name = name or (f"{problem.name}-seed{seed}" if seed is not None else problem.name)
    recording = Recording(name=rec_name, site=problem.site, rate_hz=problem.rate_hz, segments=problem.segments(),
                          time=time, gyro=gyro, accel=accel)
    return Simulation(recording, problem.truth, starts, statics, factors, seed)


def write_simulation(sim: Simulation, out_dir: str | Path) -> Path:
    """Write ``NAME.toml``, ``NAME.csv`` and ``NAME.truth.csv`` into ``out_dir``; returns the TOML path."""
    out_dir = Path(out_dir)
    toml_path = write_recording(sim.recording, out_dir / f"{sim.recording.name}.toml")
    P.write_table(out_dir / f"{sim.recording.name}.truth.csv", sim.truth, as_truth=True)
    return toml_path
