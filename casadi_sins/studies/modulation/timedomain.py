"""Time-domain check: simulate the turning IMU with drawn errors, navigate free-inertially, Monte Carlo.

Independent of the error-state model, and written with the package's own physics:

* the truth is the exact kinematics of the scheme's pieces (:func:`casadi_sins.sim.motion.kinematics_function`:
  ``C(t) = C0 R(u, w t)``, ``w_b = C^T w_ie + w u``, ``f_b = C^T (0, 0, g)``), integrated over each
  navigation step by 6-point Gauss-Legendre quadrature (:func:`casadi_sins.model.groups.physics.quadrature_nodes`);
* each run's unit errs by the output model with its drawn parameters: eq. 1 of Kang et al. 2013
  (:func:`casadi_sins.model.output.output_model_expr`) and each extra group's exact physics
  (:func:`casadi_sins.model.groups.physics.sensed_outputs`, linear in the group's values, the time offset's
  shift to first order by a central difference), white noise of densities ARW and VRW on the increments;
  the errors are the error state's (true minus nominal, scale factors ``t_ii = S_hat/S - 1``) about a
  nominal table of unit pulse weights, ``K = I`` and no bias, so the pulses are the compensated increments;
* the navigation is the package's free-inertial step (:func:`casadi_sins.nav.free_inertial.free_inertial_step_expr`:
  two-sample coning and sculling, ``q_k = q(-w_in dt) q_{k-1} q(phi)``, vertical channel held at the known
  height, position by the mean velocity), compiled once (:mod:`casadi_sins.core.compiled`) and mapped over
  the runs, one call per step.

Every run's error is taken against an error-free run through the same steps (the algorithm's own error,
common to all runs and below a metre a day, cancels).  Turns are stepped by at most ``turn_step_deg``,
dwells by at most ``dwell_step_s`` (exact for a still IMU: the body and frame rotations commute away); the
coning and sculling memory starts afresh with each piece (a step of another length).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import casadi as ca
import numpy as np

from ...core import earth
from ...core.compiled import StepChain
from ...core.earth import Site
from ...core.errors import InputError
from ...core.rotations import dcm_to_quat, quat_from_rotvec, quat_multiply
from ...model.groups.physics import quadrature_nodes, sensed_outputs
from ...model.output import apply_error_estimate, output_model_expr
from ...model.registry import N_PARAMS, SCALE_MASK, group_of, natural_scale_of
from ...nav.free_inertial import FREE_STATE, free_inertial_step_expr
from ...sim.motion import kinematics_function
from . import model as M
from .covariance import check_run, check_turn_step, output_pieces
from .schemes import Scheme, scheme_pieces
from .sources import NOISES, Sources


@dataclasses.dataclass
class Errors:
    """Drawn sensor and initial errors of a batch of runs (the state of :mod:`model`, parameters ``names``).

    Attributes
    ----------
    x0 : ndarray (N, n)
        Initial error state of each run.
    gyro_arw, accel_vrw : ndarray (N, 3)
        White-noise densities of each run, rad/sqrt(s) and m/s/sqrt(s).
    names : tuple of str
        The parameters whose errors follow the navigation errors.
    """

    x0: np.ndarray
    gyro_arw: np.ndarray
    accel_vrw: np.ndarray
    names: tuple[str, ...] = M.SHEET_NAMES

    def parameters(self) -> np.ndarray:
        """(N, parameters) each run's true parameters about the nominal table (unit pulse weights, ``K = I``,
        no bias): the 21 by the paper's update (eqs. 22-25), the extra terms their errors."""
        nominal = np.where(SCALE_MASK, 1.0, 0.0)
        core = np.array([apply_error_estimate(nominal, x) for x in self.x0[:, M.N_NAV:M.N_NAV + N_PARAMS]])
        return np.hstack([core, self.x0[:, M.N_NAV + N_PARAMS:]])


def draw_errors(sources: Sources, runs: int, rng: np.random.Generator,
                matched: bool = False) -> tuple[Errors, list[str]]:
    """``runs`` draws of every source alone, one source after the other, after one error-free run.

    ``matched``: moment-matched sampling (variance reduction): the standard normal draws of a group are
    whitened so that their second moment over the runs is exactly the identity; the drawn errors then
    have the group's covariance as their mean square, and an MC of them tests the propagation rather
    than the luck of 50 draws of one or three numbers.  Noise is never matched, nor a group of more
    numbers than ``runs`` (then drawn plainly).
    """
    n = len(sources.p0)
    labels, x0, arw, vrw = ["reference"], [np.zeros(n)], [np.zeros(3)], [np.zeros(3)]
    for group, idx in sources.groups().items():
        block = sources.p0[np.ix_(idx, idx)]
        if not np.any(block):
            continue
        vals, vecs = np.linalg.eigh(block)
        root = vecs * np.sqrt(np.clip(vals, 0.0, None))  # root @ root.T == block
        z = rng.standard_normal((runs, len(idx)))
        if matched and runs >= len(idx):  # fewer runs than numbers cannot have the identity as second moment
            z = z @ np.linalg.inv(np.linalg.cholesky(z.T @ z / runs)).T
        draws = np.zeros((runs, n))
        draws[:, idx] = z @ root.T
        x0.extend(draws @ sources.initial_map().T)  # through the alignment, if any
        arw.extend([np.zeros(3)] * runs)
        vrw.extend([np.zeros(3)] * runs)
        labels.extend([group] * runs)
    for name, dens in zip(NOISES, (sources.gyro_arw, sources.accel_vrw)):
        if not np.any(dens):
            continue
        x0.extend([np.zeros(n)] * runs)
        arw.extend([dens if name == "gyro noise" else np.zeros(3)] * runs)
        vrw.extend([dens if name == "accel noise" else np.zeros(3)] * runs)
        labels.extend([name] * runs)
    return Errors(np.array(x0), np.array(arw), np.array(vrw), tuple(sources.names)), labels


def _run_step(names: tuple[str, ...]) -> ca.Function:
    """One navigation step of one run: ``(x, p, truth, noise) -> x_next`` (module docstring).

    ``p`` the run's parameters (the 21, then the extra terms), ``truth`` the step's true increments, its
    length and the extra terms' outputs per unit value (3 x extras, gyro then accelerometer, column-major),
    ``noise`` the white noise on the gyro and accelerometer increments.
    """
    extra = len(names) - N_PARAMS
    x, p = ca.SX.sym("x", FREE_STATE), ca.SX.sym("p", len(names))
    truth, noise = ca.SX.sym("truth", 7 + 6 * extra), ca.SX.sym("noise", 6)
    h = truth[6]
    added = None
    if extra:
        added = tuple(ca.reshape(truth[7 + 3 * extra * k:7 + 3 * extra * (k + 1)], 3, extra) @ p[N_PARAMS:]
                      for k in range(2))
    dn_g, dn_a = output_model_expr(truth[0:3] + noise[0:3], truth[3:6] + noise[3:6], p[:N_PARAMS], h, added)
    return ca.Function("modulation_run_step", [x, p, truth, noise], [free_inertial_step_expr(x, dn_g, dn_a, h)])


#: Runs navigated together by one compiled step (a map over the runs); a batch is padded to a multiple.
RUNS = 32


def _runs_step(names: tuple[str, ...], runs: int) -> ca.Function:
    """:func:`_run_step` mapped over ``runs`` runs, packed for a compiled chain over the steps
    (:class:`casadi_sins.core.compiled.StepChain`)::

        (x (16 runs), const = the runs' parameters, data = (truth, first, noise (6 runs)))
            -> (x next, const, (v_E, v_N, latitude, longitude) per run)

    ``first`` is 0 on a piece's first step (the coning and sculling memory starts afresh), 1 elsewhere.
    """
    one = _run_step(names)
    mapped = one.map("modulation_runs", "serial", runs, [2], [])
    n_truth, n_params = one.size1_in(2), len(names)
    x, const = ca.MX.sym("x", FREE_STATE * runs), ca.MX.sym("const", n_params * runs)
    data = ca.MX.sym("data", n_truth + 1 + 6 * runs)
    states = ca.reshape(x, FREE_STATE, runs)
    states = ca.vertcat(states[:10, :], data[n_truth] * states[10:, :])
    after = mapped(states, ca.reshape(const, n_params, runs), data[:n_truth],
                   ca.reshape(data[n_truth + 1:], 6, runs))
    out = ca.vertcat(after[4, :], after[5, :], after[7, :], after[8, :])
    return ca.Function("modulation_runs_step", [x, const, data], [ca.vec(after), const, ca.vec(out)])


@functools.lru_cache(maxsize=None)
def run_chain(names: tuple[str, ...], runs: int = RUNS) -> StepChain:
    """:func:`_runs_step` compiled (:mod:`casadi_sins.core.compiled`), as a chain over the steps."""
    return StepChain("modulation_runs", repr((names, runs)), lambda: _runs_step(names, runs))


def step_bounds(pieces, turn_step_deg: float, dwell_step_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t0, t1, piece)`` of every navigation step: turns cut at ``turn_step_deg``, dwells at ``dwell_step_s``."""
    t0, t1, which = [], [], []
    for k, piece in enumerate(pieces):
        steps = (max(1, math.ceil(abs(piece.angle) / math.radians(turn_step_deg) - 1e-9)) if piece.axis is not None
                 else max(1, math.ceil(piece.duration / dwell_step_s - 1e-9)))
        edges = piece.t0 + piece.duration * np.arange(steps + 1) / steps
        t0.append(edges[:-1]), t1.append(edges[1:]), which.append(np.full(steps, k))
    return np.concatenate(t0), np.concatenate(t1), np.concatenate(which)


def step_truth(pieces, site: Site, t0: np.ndarray, t1: np.ndarray, names) -> np.ndarray:
    """(K, 7 + 6 extras) the ``truth`` rows of :func:`_run_step` for the steps ``[t0, t1]``: the true
    increments, the step length and what a unit value of each extra term adds to the outputs."""
    kinematics = _memo(kinematics_function(pieces, site.earth_rate, site.g))
    at = quadrature_nodes(kinematics, t0, t1)
    dv = at.integral(at.force)
    extra = tuple(names)[N_PARAMS:]
    gyro, accel = np.zeros((len(t0), 3, len(extra))), np.zeros((len(t0), 3, len(extra)))
    for k, name in enumerate(extra):  # central differences: exact for the linear terms, O(d^2) for a shift
        d = float(natural_scale_of([name])[0])
        plus, minus = (sensed_outputs(kinematics, t0, t1, {name: s * d}, [group_of(name)]) for s in (1, -1))
        gyro[:, :, k] = (plus[1] - minus[1]) / (2 * d)
        accel[:, :, k] = (plus[0] + plus[2] - minus[0] - minus[2]) / (2 * d)
    flat = [a.transpose(0, 2, 1).reshape(len(t0), -1) for a in (gyro, accel)]  # 3 x E column-major per row
    return np.hstack([at.integral(at.rate), dv, (t1 - t0)[:, None], *flat])


def _memo(kinematics):
    """``kinematics`` remembering its last times (the extra terms' outputs evaluate the same nodes again)."""
    last = {}

    def cached(t):
        """``kinematics(t)``, from memory when ``t`` is the last call's."""
        key = (t.shape, hash(np.ascontiguousarray(t).tobytes()))
        if key not in last:
            last.clear()
            last[key] = kinematics(t)
        return last[key]

    return cached


#: Navigation steps whose truth is computed at once, at most (bounds the memory of long runs).
CHUNK = 20000


def _segments(which: np.ndarray) -> list[slice]:
    """Consecutive steps of whole pieces, at most :data:`CHUNK` steps each (one piece alone may exceed it)."""
    ends = np.flatnonzero(np.r_[which[1:] != which[:-1], True]) + 1
    out, start = [], 0
    for k, end in enumerate(ends):
        if end - start > CHUNK and k and ends[k - 1] > start:
            out.append(slice(start, ends[k - 1]))
            start = ends[k - 1]
    return out + [slice(start, len(which))]


def navigate(scheme: Scheme, site: Site, hours: float, errors: Errors, rng: np.random.Generator,
             turn_step_deg: float = 1.0, dwell_step_s: float = 5.0, max_step_s: float = 60.0, progress=None):
    """Free-inertial navigation of every run; errors (v_E, v_N, north, east) at each output time.

    Returns ``(time (T,), errors (T, N, 4), reference (T, 4))``: the errors against the error-free run
    (index 0) and that run's own error (the algorithm's); the output times are those of
    :func:`covariance.propagate` with the same ``max_step_s``.  ``progress(fraction)``, if given, after
    each stretch of pieces with the fraction of the run's time navigated.
    """
    check_turn_step(turn_step_deg, "navigation step")
    if not (math.isfinite(dwell_step_s) and dwell_step_s > 0):
        raise InputError(None, f"navigation step in a dwell must be a positive number of seconds (got {dwell_step_s})")
    check_run(scheme, site, hours, max_step_s)
    pieces = output_pieces(scheme_pieces(scheme, hours * 3600.0), max_step_s)
    t0, t1, which = step_bounds(pieces, turn_step_deg, dwell_step_s)
    n = len(errors.x0)
    batches = -(-n // RUNS)
    chain = run_chain(tuple(errors.names))
    padded = np.zeros((batches * RUNS, len(errors.x0[0])))
    padded[:n] = errors.x0  # padding runs: error-free
    params = Errors(padded, np.zeros((len(padded), 3)), np.zeros((len(padded), 3)), errors.names).parameters()
    density = np.zeros((len(padded), 6))
    density[:n] = np.hstack([errors.gyro_arw, errors.accel_vrw])
    x = np.zeros((len(padded), FREE_STATE))
    x[:, 0:4] = [quat_multiply(quat_from_rotvec(-phi), dcm_to_quat(pieces[0].attitude)) for phi in padded[:, M.PHI]]
    x[:, 7], x[:, 9] = site.latitude, site.height
    flags = np.r_[0.0, (which[1:] == which[:-1]).astype(float)]  # 0 on a piece's first step
    ends = np.r_[which[1:] != which[:-1], True]
    outs = [np.column_stack([np.zeros((len(padded), 2)), x[:, 7:9]])[None]]
    for part in _segments(which):
        truth = np.hstack([step_truth(pieces, site, t0[part], t1[part], errors.names), flags[part, None]])
        rows = []
        for b in range(batches):
            runs = slice(b * RUNS, (b + 1) * RUNS)
            noise = np.zeros((len(truth), RUNS, 6))
            if density[runs].any():
                noise = density[runs] * np.sqrt(truth[:, 6])[:, None, None] * rng.standard_normal(noise.shape)
            out, last = chain(x[runs].ravel(), params[runs].ravel(), np.hstack([truth, noise.reshape(len(truth), -1)]))
            x[runs] = last.reshape(RUNS, FREE_STATE)
            rows.append(out[ends[part]].reshape(-1, RUNS, 4))
        outs.append(np.concatenate(rows, axis=1))
        if progress:
            progress(t1[part.stop - 1] / (hours * 3600.0))
    state = np.concatenate(outs)[:, :n]  # (T, N, 4): v_E, v_N, latitude, longitude
    r_m, r_n = earth.earth_radii(site.latitude)
    err = np.stack([state[..., 0], state[..., 1], (state[..., 2] - site.latitude) * (r_m + site.height),
                    state[..., 3] * (r_n + site.height) * np.cos(site.latitude)], axis=-1)
    time = np.r_[0.0, [pieces[k].t1 for k in which[ends]]]
    return time, err - err[:, :1, :], err[:, 0, :]
