"""Simulation of a problem: exact kinematics of the schedule -> raw pulses.

The true increments of a sample interval are the exact integrals

    dtheta = u (alpha(b) - alpha(a)) + int_a^b C(t)^T w_ie^n dt
    dv     = int_a^b C(t)^T (0, 0, g) dt

evaluated with 6-point Gauss-Legendre quadrature on every piece of the interval between motion
breakpoints (error below 1e-18 rad per sample; the integrands are analytic inside a piece).  White
noise and bias instability are added to the true increments and the output model (eq. 1,
:func:`model.output.output_model`) turns them into pulses; the extra terms of the truth add their
exact physics (:func:`model.groups.physics.sensed_outputs`); integer pulses carry their remainder.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.inputs import memory_available
from ..core.rotations import NED_TO_ENU, enu_to_euler
from ..core.units import ARCSEC, ARW_UNIT, DEG_PER_H, UG
from ..core.files import write_files
from ..data.description import recording_files
from ..data.problem import Problem
from ..data.recording import Recording
from ..data.tables import table_text
from ..model.groups.physics import sensed_outputs
from ..model.output import output_model
from ..model.parameters import ParameterSet
from ..model.registry import ACCEL_SCALE, GROUPS, GYRO_SCALE, N_PARAMS, groups_in
from .hand import hand_increments, plan_hand
from .motion import MotionPiece, Sway, Translation, kinematics_function, plan_motion

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(6)


@dataclasses.dataclass
class Simulation:
    """A simulated recording with everything that is true about it."""

    recording: Recording
    truth: ParameterSet
    start_attitudes: dict[int, np.ndarray]  # group -> true C_b^n at the start of the group
    static_attitudes: list[np.ndarray]  # true C_b^n in each static segment, in order
    rate_factors: list[float]
    seed: int | None
    sway: "Sway | None" = None
    translation: "Translation | None" = None


#: Sample pieces integrated at once by quadrature (bounds the memory of long recordings).
_QUADRATURE_CHUNK = 20000


def true_increments(pieces: list[MotionPiece], n_samples: int, dt: float, earth_rate: np.ndarray, gravity: float,
                    sway: Sway | None = None, progress=None, translation: Translation | None = None):
    """Exact true ``(dtheta, dv)`` per sample interval ``[(k) dt, (k+1) dt]``, k = 0..n-1; ``progress(fraction)``,
    if given, after each piece of motion with the fraction of the experiment's time done.

    Without base motion a static piece is integrated in closed form; everything else by 6-point
    Gauss-Legendre quadrature on each sample's part of the piece (the integrands are analytic
    there): ``dtheta = int C^T (w_ie + w_sway) dt + u (alpha(b) - alpha(a))``, ``dv = int C^T f^n dt``
    with ``f^n = g^n`` plus the base's acceleration and Coriolis term (:class:`motion.Translation`).
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
            if piece.axis is None and sway is None and translation is None:
                integral = (b - a)[:, None, None] * (piece.attitude.T @ references)[None]
            else:
                nodes = a[:, None] + (b - a)[:, None] * (1.0 + _GAUSS_X[None, :]) / 2.0
                weights = (b - a)[:, None] * _GAUSS_W[None, :] / 2.0
                c_nodes = piece.attitude_at(nodes)  # (M, J, 3, 3)
                if sway is None and translation is None:
                    values = np.swapaxes(c_nodes, -1, -2) @ references  # (M, J, 3, 2)
                else:
                    rate = np.broadcast_to(earth_rate, nodes.shape + (3,))
                    force = np.broadcast_to([0.0, 0.0, gravity], nodes.shape + (3,))
                    if sway is not None:
                        c_nodes = sway.attitude(nodes) @ c_nodes
                        rate = rate + sway.rate(nodes)  # (M, J, 3)
                    if translation is not None:
                        force = force + translation.force(nodes, earth_rate)
                    values = np.swapaxes(c_nodes, -1, -2) @ np.stack([rate, force], axis=-1)
                integral = np.einsum("mj,mjkl->mkl", weights, values)
            turned = (np.zeros((len(a), 3)) if piece.axis is None
                      else np.outer(piece.angle_at(b) - piece.angle_at(a), piece.axis))
            np.add.at(dtheta, sample, integral[:, :, 0] + turned)
            np.add.at(dv, sample, integral[:, :, 1])
        if progress:
            progress(min(piece.t1 / edges[-1], 1.0))
    return dtheta, dv


def sensor_extras(kinematics, problem: Problem, n_samples: int, dt: float):
    """The extra groups of the truth in every sample: ``(dv_f, gyro_extra, accel_extra)``
    (:func:`model.groups.physics.sensed_outputs`, each group's exact physics by quadrature, in chunks), from
    ``kinematics(t) -> (C_b^n, w_b, w_dot_b, f_b)``."""
    truth = problem.truth.as_dict()
    present = [GROUPS[k] for k in groups_in(problem.truth.names)]
    parts = []
    for first in range(0, n_samples, _QUADRATURE_CHUNK):
        t0 = np.arange(first, min(first + _QUADRATURE_CHUNK, n_samples)) * dt
        parts.append(sensed_outputs(kinematics, t0, t0 + dt, truth, present))
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


#: Memory a simulation holds per sample (bytes; measured about 250 B: motion, increments, noise, recording).
SIMULATION_BYTES_PER_SAMPLE = 300.0


def check_simulation_memory(problem: Problem) -> None:
    """Refuse, before anything is allocated, a problem whose simulation needs more memory than is available
    (naming the problem, its samples and the memory).

    Raises
    ------
    InputError
    """
    samples = problem.duration * problem.rate_hz
    need, free = samples * SIMULATION_BYTES_PER_SAMPLE, memory_available()
    if need > free:
        raise InputError(problem.source, f"{problem.name}: {problem.duration:.4g} s at {problem.rate_hz:g} Hz is "
                         f"{samples:.3g} samples; simulating them needs about {need / 1e9:.3g} GB of memory, "
                         f"{max(free, 0.0) / 1e9:.3g} GB are available")


def simulate(problem: Problem, seed: int | None = 0, noise: bool = True, name: str | None = None,
             progress=None) -> Simulation:
    """Simulate the problem's experiment (``progress(fraction)``, if given, as the motion is integrated).

    Parameters
    ----------
    problem : Problem
    seed : int or None
        Seed of every random draw (deviations and noise).
    noise : bool
        ``False`` leaves out the sensor noise (not the deviations), for checks.
    """
    check_simulation_memory(problem)
    rng = np.random.default_rng(seed)
    dev = problem.deviations
    dt = 1.0 / problem.rate_hz
    sway = translation = None
    if problem.hand is not None:  # a session by hand (sim.hand)
        motion = plan_hand(problem, rng)
        n_samples = int(round(motion.pieces[-1].t1 * problem.rate_hz))
        dtheta, dv = hand_increments(motion, n_samples, dt, problem.hand.clock_jitter, rng)
        kinematics, starts, statics, factors = motion.kinematics, {1: motion.rest_attitudes[0]}, motion.rest_attitudes, []
    else:
        pieces, starts, statics, factors = plan_motion(problem, rng)
        # drawn after the motion, so that adding sway or translation leaves the other draws of a seed as they were
        sway = (Sway.draw(tuple(a * ARCSEC for a in dev.sway_amplitude_arcsec), dev.sway_period_s,
                          dev.sway_components, rng) if dev.sways else None)
        translation = (Translation.draw(dev.translation_amplitude_m, dev.translation_period_s,
                                        dev.translation_components, dev.translation_axes,
                                        dev.translation_peak_mg * 1e-3 * problem.site.g, rng)
                       if dev.translates else None)
        n_samples = int(round(pieces[-1].t1 * problem.rate_hz))
        dtheta, dv = true_increments(pieces, n_samples, dt, problem.site.earth_rate, problem.site.g, sway, progress,
                                     translation)
        kinematics = kinematics_function(pieces, problem.site.earth_rate, problem.site.g, sway, translation)
    truth = problem.truth
    # what the extra groups add to K_g dtheta and K_a dv in the output model
    gyro_extra, accel_extra = np.zeros_like(dtheta), np.zeros_like(dv)
    if any(truth[n] != 0.0 for n in truth.names[N_PARAMS:]):
        dv, gyro_extra, accel_extra = sensor_extras(kinematics, problem, n_samples, dt)
    if noise:
        gyro_white = np.hypot(dev.gyro_noise_deg_h * DEG_PER_H * dt, dev.gyro_arw_deg_rth * ARW_UNIT * np.sqrt(dt))
        accel_white = np.hypot(dev.accel_noise_ug * UG * dt, dev.accel_vrw_ug_rthz * UG * np.sqrt(dt))
        dtheta = dtheta + rng.standard_normal(dtheta.shape) * gyro_white
        dv = dv + rng.standard_normal(dv.shape) * accel_white
        dtheta += dt * gauss_markov(n_samples, dt, dev.gyro_bias_instability_deg_h * DEG_PER_H,
                                    dev.gyro_bias_tau_s, rng)
        dv += dt * gauss_markov(n_samples, dt, dev.accel_bias_instability_ug * UG, dev.accel_bias_tau_s, rng)
    gyro, accel = output_model(dtheta, dv, truth.core, dt)
    gyro = gyro + gyro_extra / truth.core[GYRO_SCALE]
    accel = accel + accel_extra / truth.core[ACCEL_SCALE]
    if problem.deviations.quantize:
        gyro, accel = quantize(gyro), quantize(accel)
    time = np.round(np.arange(1, n_samples + 1) * dt, 9)
    rec_name = name or (f"{problem.name}-seed{seed}" if seed is not None else problem.name)
    recording = Recording(name=rec_name, site=problem.site, rate_hz=problem.rate_hz, segments=problem.segments(),
                          time=time, gyro=gyro, accel=accel,
                          reference=base_reference(time, sway, dev.reference_noise_arcsec * ARCSEC, rng)
                          if dev.reference_attitude else None)
    if sway is not None:  # the true start of a group on a swaying base
        first = {seg.group: seg.start for seg in reversed(recording.segments)}
        starts = {g: sway.attitude(np.array(first[g])) @ c for g, c in starts.items()}
    return Simulation(recording, problem.truth, starts, statics, factors, seed, sway, translation)


def base_reference(time: np.ndarray, sway: Sway | None, noise_rad: float, rng: np.random.Generator) -> np.ndarray:
    """An attitude reference on the base (a master INS): roll, pitch, heading (rad, N x 3) of the base at the
    samples' ends, level and north at rest (:func:`core.rotations.euler_to_enu`), with white noise."""
    attitude = np.broadcast_to(NED_TO_ENU, time.shape + (3, 3))
    if sway is not None:
        attitude = sway.attitude(time) @ NED_TO_ENU
    return enu_to_euler(attitude) + rng.standard_normal((len(time), 3)) * noise_rad


def simulation_files(sim: Simulation, out_dir: str | Path) -> dict:
    """``{path: content}`` of ``NAME.toml``, ``NAME.csv`` and ``NAME.truth.csv`` in ``out_dir``."""
    out_dir = Path(out_dir)
    files = recording_files(sim.recording, out_dir / f"{sim.recording.file_stem}.toml")
    files[out_dir / f"{sim.recording.file_stem}.truth.csv"] = table_text(sim.truth, as_truth=True).encode()
    return files


def write_simulation(sim: Simulation, out_dir: str | Path) -> Path:
    """Write ``NAME.toml``, ``NAME.csv`` and ``NAME.truth.csv`` into ``out_dir`` together; returns the TOML path."""
    write_files(simulation_files(sim, out_dir))
    return Path(out_dir) / f"{sim.recording.file_stem}.toml"
