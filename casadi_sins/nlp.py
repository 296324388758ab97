"""The CasADi/Ipopt estimator: calibration as one nonlinear least-squares problem.

Decision variables
    the 21 parameters as deviations from a reference (the starting values) in natural units (ug, ppm
    of the value, arcsec, deg/h), and per group a small rotation (arcsec, ENU) of the start attitude
    away from the coarse alignment: the positions' deviations from nominal are nuisance variables,
    the alignment is only the starting guess (physics pitfall 6).
Graph
    every group is navigated by the one strapdown step (:func:`strapdown.step_function`) chained
    with ``mapaccum``; the raw pulses enter through the one compensation expression
    (:func:`parameters.compensate_expr`).  Static segments are stepped in blocks of summed pulses
    (exact for the output model, and the strapdown step is exact for a body at rest; on a swaying
    base in short steps), rotations in 40 ms steps (the error grows as rate^2 x step^3: below 0.001
    natural units at 40 ms, see the benchmarks).
Residuals
    the navigated velocity at observation times in the static segments (every second; true velocity
    zero), and per static segment the mean compensated gyro rate against the Earth rate seen in the
    navigated attitude.  The velocity sees gyro errors only through the slow attitude drift; the
    segment mean measures them directly.  A velocity observation after a rotation carries the
    velocity step across it; ``use_rotation_steps=False`` leaves a free velocity offset there, for
    units whose lever arms or timing offsets make those steps unmodelled.
Solve, in two stages
    1. Ipopt from the rough values, derivatives by algorithmic differentiation, Gauss-Newton Hessian
       ``J^T J``, with the residuals weighted for white accelerometer noise alone (velocity
       differences over the square root of their samples, pitfall 7): quick, and near the answer.
    2. Generalised least squares under the full noise model (:mod:`kalman`): angle and velocity
       random walk, the gyro noise shared by the gyro means and the velocity, pulse quantization,
       bias instability, base sway.  Gauss-Newton steps on the Kalman-whitened residuals and
       Jacobian, re-linearised, until a step is below 1 % of a sigma; every step is reported.
Noise
    measured from the raw pulses of the static segments, independently of the fit
    (:func:`noise.estimate_sensor_noise`), or given by a datasheet; terms the data cannot determine
    (coarse pulses hide the white noise) are estimated from the fit's residuals (variance
    components).  The fit's residuals then check the model (:mod:`diagnostics`); a check that fails
    inflates the sigma and writes a warning.
Uncertainty
    ``(J_w^T J_w)^-1`` of the whitened Jacobian at the solution, times the variance factor when the
    residuals exceed the noise model.
"""

from __future__ import annotations

import contextlib
import dataclasses
import signal
import threading
import time
from typing import Callable

import casadi as ca
import numpy as np
import scipy.sparse as sp

from . import parameters as P
from .errormodel import quat_to_dcm_batch
from .frames import small_rotation
from .initial import rough_parameters
from .kalman import GroupTrack, NoiseSystem
from .noise import ACCEL_VRW_FLOOR, GYRO_ARW_FLOOR, NoisePlan, SensorNoise, describe_motion, plan_noise
from .recording import Recording
from .result import CalibrationError, CalibrationResult
from .strapdown import (Q, dcm_to_quat, group_alignment, navigation_constants, quat_from_rotvec, quat_multiply,
                        quat_to_dcm, step_function)
from .units import ARCSEC, DEG_PER_H, UG

SIGMA_MEANING = ("1-sigma from the Gauss-Newton covariance (J^T W J)^-1 of the velocity and gyro residuals, "
                 "W from the noise model (raw-data estimate, datasheet, fit), times the variance factor when "
                 "the residuals exceed the model")

#: Rotation step and static step on a swaying base (s).
ROTATION_STEP_S = 0.04
SWAY_STATIC_STEP_S = 0.1
#: Mean square of the whitened residuals after rotations over that of the others, above which the steps
#: are taken as unmodelled (F-test: the 99.9 % point for 27 against 3500 degrees of freedom is 2.0).
STEP_CONSISTENCY_LIMIT = 3.0
RANK_TOLERANCE = 1e-7
#: Gauss-Newton steps of the generalised least squares stop below this fraction of a sigma.
GLS_TOLERANCE = 0.01
#: A step this small (in sigma) is taken as the last: the next is smaller by a factor ~1e-4 x step
#: (measured: steps of 2.2, 0.11 and 20 sigma were followed by 0.001, 6e-7 and 0.017), well below
#: GLS_TOLERANCE, so the residuals are updated linearly instead of evaluating the graph again.
GLS_LINEAR_STEP = 0.5
GLS_MAX_STEPS = 6


@dataclasses.dataclass
class GroupSteps:
    """How one group is stepped and observed."""

    group: int
    start_time: float  # start of the group's first sample interval, s
    pulses_gyro: np.ndarray  # (3, M) pulse sums per step
    pulses_accel: np.ndarray
    step_dt: np.ndarray  # (M,) step length, s
    previous_scale: np.ndarray  # (M,) 1 where the previous step has the same length, else 0
    step_segment: np.ndarray  # (M,) static segment number of each step, -1 outside static segments
    first: np.ndarray  # (M,) first sample of each step (index into the recording)
    stop: np.ndarray  # (M,) one past the last sample of each step
    observed: np.ndarray  # (K,) indices of steps whose end velocity is observed
    samples_between: np.ndarray  # (K,) samples between consecutive observations (first: since the start)
    after_rotation: np.ndarray  # (K,) True for the first observation after a rotation
    observed_time: np.ndarray  # (K,) time of each observation, s
    segment_of: np.ndarray  # (K,) segment number of each observation

    def middle_step(self, segment: int) -> int:
        """The step whose end attitude a static segment's gyro mean compares the Earth rate in."""
        steps = np.flatnonzero(self.step_segment == segment)
        return int(steps[len(steps) // 2])

    @property
    def segment_start(self) -> np.ndarray:
        """(M,) True at the first step of each static segment."""
        seg = self.step_segment
        return (seg >= 0) & (seg != np.concatenate([[-1], seg[:-1]]))


def plan_steps(rec: Recording, group: int, observe_s: float = 1.0, rotation_step_s: float = 0.0,
               static_step_s: float | None = None) -> GroupSteps:
    """Split a group's samples into navigation steps and choose the observed ones.

    Static segments are stepped in ``static_step_s`` blocks (default ``observe_s``) and observed every
    ``observe_s`` and at their end; rotations in ``rotation_step_s`` steps (0: every sample).
    """
    static_step_s = observe_s if static_step_s is None else static_step_s
    span = rec.group_samples(group)
    block = max(1, int(round(static_step_s * rec.rate_hz)))
    every = max(1, int(round(observe_s / static_step_s)))
    rotation_block = max(1, int(round(rotation_step_s * rec.rate_hz)))
    bounds: list[tuple[int, int, int, bool]] = []  # (first sample, stop, static segment number or -1, observed)
    cursor = span.start
    for seg in rec.group_segments(group):
        sl = rec.segment_samples(seg)
        while cursor < sl.start:  # samples between segments: one step each
            bounds.append((cursor, cursor + 1, -1, False))
            cursor += 1
        size = block if seg.is_static else rotation_block
        n = sl.stop - sl.start
        count = max(1, int(round(n / size)))
        edges = np.round(np.linspace(sl.start, sl.stop, count + 1)).astype(int)
        for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
            observed = seg.is_static and ((k + 1) % every == 0 or k == count - 1)
            bounds.append((a, b, seg.number if seg.is_static else -1, observed))
        cursor = sl.stop
    while cursor < span.stop:
        bounds.append((cursor, cursor + 1, -1, False))
        cursor += 1
    cum_g = np.vstack([np.zeros(3), np.cumsum(rec.gyro, axis=0)])
    cum_a = np.vstack([np.zeros(3), np.cumsum(rec.accel, axis=0)])
    first = np.array([b[0] for b in bounds])
    stop = np.array([b[1] for b in bounds])
    static_of = np.array([b[2] for b in bounds])
    lengths = (stop - first).astype(float)
    observed = np.flatnonzero([b[3] for b in bounds])
    obs_stop = stop[observed]
    between = np.diff(np.concatenate([[span.start], obs_stop]))
    seg_numbers = static_of[observed]
    spans_rotation = np.concatenate([[False], seg_numbers[1:] != seg_numbers[:-1]])
    return GroupSteps(
        group=group,
        start_time=float(rec.time[span.start] - rec.dt),
        pulses_gyro=(cum_g[stop] - cum_g[first]).T,
        pulses_accel=(cum_a[stop] - cum_a[first]).T,
        step_dt=lengths * rec.dt,
        # coning and sculling use the previous increment as a rate estimate: meaningless across a change of
        # step length (a 1 s block after a rotation sample would extrapolate the rotation into rest)
        previous_scale=(lengths == np.concatenate([[lengths[0]], lengths[:-1]])).astype(float),
        step_segment=static_of,
        first=first,
        stop=stop,
        observed=observed,
        samples_between=between.astype(float),
        after_rotation=spans_rotation,
        observed_time=rec.time[obs_stop - 1],
        segment_of=seg_numbers,
    )


def natural_scale(reference: np.ndarray, names=P.NAMES) -> np.ndarray:
    """``d(parameters)/d(natural-unit variables)``: ppm of the value for scale factors, else the natural unit."""
    return np.where(P.scale_mask_of(names), reference * 1e-6, P.natural_scale_of(names))


def natural_to_parameters(z, reference: np.ndarray, names=P.NAMES):
    """Parameters (SI) from natural-unit deviations ``z`` from ``reference`` (CasADi or NumPy)."""
    scale = natural_scale(reference, names)
    if isinstance(z, (ca.MX, ca.SX)):
        return ca.DM(reference) + ca.diag(ca.DM(scale)) @ z
    return reference + scale * np.asarray(z)


@dataclasses.dataclass
class Problem:
    """The built NLP: CasADi functions of the decision vector, and what each residual row is.

    Residual rows, in time order per group: three per velocity observation (m/s, ENU) and three per
    static segment's mean gyro rate (rad/s, body), the latter after the segment's last velocity.
    """

    residuals: ca.Function  # w -> r
    jacobian: ca.Function  # w -> (r, J)
    trajectory: ca.Function  # w -> quaternions at every step end, all groups side by side (4, sum M)
    n_variables: int
    n_residuals: int
    kind: np.ndarray  # (m,) 0 velocity, 1 gyro mean
    row_group: np.ndarray  # (m,) group of each row
    row_segment: np.ndarray  # (m,) static segment number of each row
    row_after_rotation: np.ndarray  # (m,) velocity rows of the first observation after a rotation
    row_samples: np.ndarray  # (m,) samples since the previous velocity observation (0 for gyro rows)
    row_first: np.ndarray  # (m,) the group's first velocity observation (known zero velocity before it)
    events: list[dict[int, list[tuple]]]  # per group: step -> observations (see kalman.GroupTrack)
    groups: list[GroupSteps]
    reference: np.ndarray
    start_attitudes: dict[int, np.ndarray]
    build_time: float
    residual_index: list[tuple]  # (group, kind label, observation/segment, axis) per row
    names: tuple[str, ...] = P.NAMES  # the parameters, in the order of the first variables

    def variable_names(self) -> list[str]:
        return list(self.names) + [f"start attitude of group {p.group} ({axis})" for p in self.groups
                                   for axis in "ENU"]

    def tracks(self, trajectory: np.ndarray, use_rotation_steps: bool, motions=None) -> list[GroupTrack]:
        """The noise model's view of the groups, along the navigated attitude ``trajectory``."""
        sway = {m.segment: m.gyro_mean_variance for m in (motions or [])}
        tracks, offset = [], 0
        for plan, events in zip(self.groups, self.events):
            m = len(plan.step_dt)
            tracks.append(group_track(plan, events, self.start_attitudes[plan.group],
                                      trajectory[:, offset:offset + m], use_rotation_steps, sway))
            offset += m
        return tracks


def group_track(plan: GroupSteps, events: dict, start_attitude: np.ndarray, quats: np.ndarray,
                use_rotation_steps: bool, sway: dict | None = None) -> GroupTrack:
    """The noise model's view of one group: its steps along the navigated attitude (quaternions at
    every step end, ``(4, M)``), the observations at each step, and the sway of its static segments."""
    sway = sway or {}
    after = quat_to_dcm_batch(quats.T)
    before = np.concatenate([start_attitude[None], after[:-1]])
    attitude = 0.5 * (before + after)
    seg_start = plan.segment_start
    free = np.zeros(len(plan.step_dt), bool)
    if not use_rotation_steps:
        first_static = np.flatnonzero(seg_start)[:1]
        free = seg_start.copy()
        free[first_static] = False
    numbers = np.unique(plan.step_segment[plan.step_segment >= 0])
    durations = {int(s): float(plan.step_dt[plan.step_segment == s].sum()) for s in numbers}
    return GroupTrack(plan.start_time, plan.step_dt, attitude, seg_start, plan.step_segment >= 0, free, events,
                      durations, {s: sway[s] for s in durations if s in sway},
                      {int(s): plan.middle_step(int(s)) for s in numbers})


def build_problem(rec: Recording, reference: np.ndarray, observe_s: float = 1.0,
                  rotation_step_s: float = ROTATION_STEP_S, static_step_s: float | None = None,
                  names: tuple[str, ...] = P.NAMES) -> Problem:
    """Build the symbolic NLP for a recording around ``reference`` parameters (ordered like ``names``: the
    21, then any extra groups of :data:`parameters.EXTRA_GROUPS`)."""
    from .extended import correction_expr, sample_regressors, static_rates, step_regressors

    t0 = time.perf_counter()
    groups = rec.group_ids
    n_params = len(names)
    n_var = n_params + 3 * len(groups)
    w = ca.MX.sym("w", n_var)
    all_params = natural_to_parameters(w[:n_params], reference, names)
    params = all_params[: P.N_PARAMS]
    extended = n_params > P.N_PARAMS
    if extended:
        per_sample, boundary = sample_regressors(rec.gyro, rec.accel, reference, rec.dt,
                                                 static_rates(rec, reference))
    earth_dt, gravity_dt = navigation_constants(rec)
    parts, trajectories = [], []
    kind, row_group, row_segment, after, samples, first, index = [], [], [], [], [], [], []
    plans, starts, all_events = [], {}, []
    for gi, group in enumerate(groups):
        plan = plan_steps(rec, group, observe_s, rotation_step_s, static_step_s)
        plans.append(plan)
        start = group_alignment(rec, group, reference)
        starts[group] = start
        steps = len(plan.step_dt)
        dt_row = ca.DM(plan.step_dt).T
        correction = (correction_expr(all_params[P.N_PARAMS:], names[P.N_PARAMS:],
                                      ca.DM(step_regressors(per_sample, boundary, plan.first, plan.stop)))
                      if extended else None)
        dtheta, dv = P.compensate_expr(ca.DM(plan.pulses_gyro), ca.DM(plan.pulses_accel), params, dt_row,
                                       correction)
        rotvec = w[n_params + 3 * gi: n_params + 3 * gi + 3] * ARCSEC
        q0 = quat_multiply(quat_from_rotvec(rotvec), ca.DM(dcm_to_quat(start)))
        x0 = ca.vertcat(q0, ca.DM.zeros(3), dtheta[:, 0], dv[:, 0])
        chain = step_function().mapaccum("strapdown_chain", steps)
        ratio = plan.step_dt[None, :] / rec.dt
        states = chain(x0, dtheta, dv, ca.DM(earth_dt[:, None] * ratio), ca.DM(gravity_dt[:, None] * ratio),
                       ca.DM(plan.previous_scale).T)
        trajectories.append(states[Q, :])
        events: dict[int, list[tuple]] = {}
        row = sum(p.shape[0] for p in parts)
        last_obs_of = {int(s): int(plan.observed[plan.segment_of == s][-1]) for s in np.unique(plan.segment_of)}
        pieces = []
        for k, step in enumerate(plan.observed):
            pieces.append(states[4:7, int(step)])
            events.setdefault(int(step), []).append(("v", row))
            kind += [0] * 3
            row_group += [group] * 3
            row_segment += [int(plan.segment_of[k])] * 3
            after += [bool(plan.after_rotation[k])] * 3
            samples += [float(plan.samples_between[k])] * 3
            first += [k == 0] * 3
            label = "rotation step" if plan.after_rotation[k] else "velocity"
            index += [(group, label, k, axis) for axis in range(3)]
            row += 3
            seg_number = int(plan.segment_of[k])
            if step == last_obs_of[seg_number]:
                # mean gyro rate of the static segment against the Earth rate seen in the navigated attitude
                in_seg = plan.step_segment == seg_number
                cols = list(np.flatnonzero(in_seg))
                duration = float(plan.step_dt[in_seg].sum())
                mean_rate = ca.sum2(dtheta[:, cols]) / duration
                mid = plan.middle_step(seg_number)
                earth_in_body = quat_to_dcm(states[Q, mid]).T @ ca.DM(rec.site.earth_rate)
                pieces.append(mean_rate - earth_in_body)
                events[int(step)].append(("g", row, seg_number))
                kind += [1] * 3
                row_group += [group] * 3
                row_segment += [seg_number] * 3
                after += [False] * 3
                samples += [0.0] * 3
                first += [False] * 3
                index += [(group, "gyro", seg_number, axis) for axis in range(3)]
                row += 3
        parts.append(ca.vertcat(*pieces))
        all_events.append(events)
    r = ca.vertcat(*parts)
    residuals = ca.Function("residuals", [w], [r])
    jacobian = ca.Function("residuals_jacobian", [w], [r, ca.jacobian(r, w)])
    trajectory = ca.Function("trajectory", [w], [ca.horzcat(*trajectories)])
    return Problem(residuals, jacobian, trajectory, n_var, r.shape[0], np.array(kind), np.array(row_group),
                   np.array(row_segment), np.array(after), np.array(samples), np.array(first), all_events,
                   plans, reference, starts, time.perf_counter() - t0, index, tuple(names))


def quick_weights(problem: Problem, noise: SensorNoise, dt: float, use_rotation_steps: bool,
                  motions=()) -> sp.csr_matrix:
    """The quick weighting of stage 1: white accelerometer noise alone.

    Consecutive velocity observations of a group are differenced and divided by the random walk over
    the samples between them (pitfall 7); a difference across a rotation is dropped when the steps are
    not used.  Gyro means are divided by the white gyro noise of a segment and its sway.
    """
    sway = {m.segment: m.gyro_mean_variance for m in motions}
    model = noise.complete()
    vrw = max(float(np.mean(model.accel_vrw)), ACCEL_VRW_FLOOR)
    arw = max(float(np.mean(model.gyro_arw)), GYRO_ARW_FLOOR)
    rows, cols, vals = [], [], []
    out = 0
    velocity_rows = np.flatnonzero(problem.kind == 0)
    previous = {}
    for i in velocity_rows[::3]:
        group = problem.row_group[i]
        keep = use_rotation_steps or not problem.row_after_rotation[i]
        weight = 1.0 / (vrw * np.sqrt(problem.row_samples[i] * dt))
        if keep:
            for axis in range(3):
                rows.append(out + axis), cols.append(i + axis), vals.append(weight)
                if group in previous:
                    rows.append(out + axis), cols.append(previous[group] + axis), vals.append(-weight)
            out += 3
        previous[group] = i
    for i in np.flatnonzero(problem.kind == 1)[::3]:
        seg = problem.row_segment[i]
        plan = next(p for p in problem.groups if p.group == problem.row_group[i])
        duration = float(plan.step_dt[plan.step_segment == seg].sum())
        variance = arw**2 / duration + sway.get(seg, np.zeros(3))
        for axis in range(3):
            rows.append(out + axis), cols.append(i + axis), vals.append(1.0 / np.sqrt(variance[axis]))
        out += 3
    return sp.csr_matrix((vals, (rows, cols)), shape=(out, problem.n_residuals))


def _solve_ipopt(problem: Problem, weights: sp.csr_matrix, hessian: str, tolerance: float, max_iterations: int,
                 progress: Callable[[str], None] | None):
    w = ca.MX.sym("w", problem.n_variables)
    d = ca.DM(weights.tocsc())
    r = ca.mtimes(d, problem.residuals(w))  # not the jacobian function's r: its derivative would hold J's
    scale = 1.0 / weights.shape[0]  # mean square: the tolerance does not depend on the recording's length
    nlp = {"x": w, "f": 0.5 * scale * ca.dot(r, r)}
    # The variables are in natural units already: Ipopt's gradient scaling at the (far-off) rough start
    # would shrink the objective by ~1e-6 and stall the line search at round-off.  The gradient of the
    # chained navigation has a round-off floor near 1e-8; a gradient of 1e-7 moves the estimate by
    # ~1e-4 of its sigma.  Also stop when the objective stalls: with noise-free data or very unequal
    # weights the gradient's round-off floor can exceed any fixed tolerance although Gauss-Newton has
    # converged.
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": tolerance,
            "ipopt.acceptable_tol": 1e20, "ipopt.acceptable_obj_change_tol": 1e-12, "ipopt.acceptable_iter": 2,
            "ipopt.max_iter": max_iterations, "ipopt.sb": "yes", "ipopt.nlp_scaling_method": "none"}
    if hessian == "gauss-newton":
        jw = ca.mtimes(d, problem.jacobian(w)[1])
        sigma = ca.MX.sym("sigma")
        opts["hess_lag"] = ca.Function("nlp_hess_l", [w, ca.MX.sym("p", 0, 1), sigma, ca.MX.sym("lam_g", 0, 1)],
                                       [sigma * scale * ca.triu(jw.T @ jw)], ["x", "p", "lam_f", "lam_g"],
                                       ["triu_hess_gamma_x_x"])
    elif hessian == "limited-memory":
        opts["ipopt.hessian_approximation"] = "limited-memory"
    elif hessian != "exact":
        raise ValueError(f"unknown hessian {hessian!r}")
    solver = ca.nlpsol("calibration", "ipopt", nlp, opts)
    with _interruptions() as interrupted:
        sol = solver(x0=np.zeros(problem.n_variables))
    if interrupted:  # CasADi stops Ipopt on Ctrl-C and reports an exception: it is an interruption
        raise KeyboardInterrupt
    stats = solver.stats()
    if progress:
        progress(f"nlp: ipopt {stats['return_status']} after {stats['iter_count']} iterations, "
                 f"cost {float(sol['f']):.6g}")
    return np.asarray(sol["x"]).ravel(), stats


#: Static segments longer than this many observations are observed more sparsely (long files).
OBSERVATIONS_PER_SEGMENT = 300


@contextlib.contextmanager
def _interruptions():
    """Record a Ctrl-C that arrives while C++ code runs (CasADi turns it into a failed solve)."""
    seen: list[bool] = []
    if threading.current_thread() is not threading.main_thread():
        yield seen
        return

    def handler(signum, frame):
        seen.append(True)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield seen
    finally:
        signal.signal(signal.SIGINT, previous)


def default_observation_spacing(rec: Recording) -> float:
    """Seconds between static velocity observations: 1 s, or 5 s for integer pulse counters; longer when
    static segments last more than :data:`OBSERVATIONS_PER_SEGMENT` of them.

    Integer pulses add a white velocity noise of about one pulse to every observation (pitfall 8), far
    from white when the pulse is much larger than the sensor noise (a sawtooth); over 5 s the random
    walk of the accelerometer noise dominates it again, and a static base loses nothing by it.  In
    segments of many minutes the slope and curvature the parameters leave are fixed as well by a few
    hundred observations as by thousands (the noise model holds at any spacing), and the graph and the
    filter grow with the observations: a 10 h file is observed every 10 s.
    """
    integral = np.all(rec.accel == np.round(rec.accel)) and np.all(rec.gyro == np.round(rec.gyro))
    base = 5.0 if integral else 1.0
    durations = [s.end - s.start for s in rec.static_segments]
    typical = float(np.median(durations)) if durations else 0.0
    return base * max(1.0, float(np.ceil(typical / (OBSERVATIONS_PER_SEGMENT * base))))


def model_groups(model) -> tuple[str, ...]:
    """The extra groups a model argument asks for (``"auto"``: all of them, to be selected)."""
    if model in ("21", None):
        return ()
    if model in ("extended", "auto"):
        return P.MODELS["extended"]
    groups = tuple(model)
    P.model_names(groups)  # names unknown groups
    return groups


def calibrate_nlp(rec: Recording, initial: P.ParameterSet | None = None, hessian: str = "gauss-newton",
                  static_block_s: float | None = None, rotation_step_s: float = ROTATION_STEP_S,
                  use_rotation_steps: bool | str = "auto", tolerance: float = 1e-7, max_iterations: int = 100,
                  progress: Callable[[str], None] | None = None, noise: SensorNoise | None = None,
                  static_step_s: float | None = None, model="21") -> CalibrationResult:
    """Calibrate a recording by nonlinear least squares over all rotations (CasADi + Ipopt).

    Parameters
    ----------
    rec : Recording
    initial : ParameterSet, optional
        Starting values and reference of the natural-unit variables; default the rough values (extra
        terms: their prior, 0).
    hessian : {"gauss-newton", "exact", "limited-memory"}
        Hessian of Ipopt's stage.
    static_block_s : float, optional
        Seconds between velocity observations in static segments (default
        :func:`default_observation_spacing`).
    rotation_step_s : float
        Rotation step (40 ms: a method error below 0.001 natural units on the paper's problem, see
        benchmarks/bench_nlp.py; the number of steps, hence the time, does not grow with the sample rate).
    use_rotation_steps : bool or "auto"
        Keep the velocity steps across rotations.  ``"auto"`` keeps them unless they disagree with the
        static residuals (F-test, :data:`STEP_CONSISTENCY_LIMIT`): lever arms or timing offsets of a
        real unit make velocity steps that the model cannot explain.
    tolerance : float
        Ipopt's tolerance on the gradient of the mean square weighted residual (natural units).
    noise : SensorNoise, optional
        Datasheet noise terms; those not given are estimated from the data.
    static_step_s : float, optional
        Navigation step in static segments (default: the observation spacing; on a swaying base
        :data:`SWAY_STATIC_STEP_S`).
    model : {"21", "extended", "auto"} or tuple of group keys
        The parameters: the paper's 21; with every extra group of :data:`parameters.EXTRA_GROUPS`
        (quadratic scale, lever arms, time offset); or ``"auto"``: the extra groups the data support
        (each group's Wald statistic in the extended fit against the Bayesian information criterion,
        ``k ln n``), refitted with those alone.  Terms not estimated stay at their prior (0).

    Raises
    ------
    CalibrationError
        Ipopt fails to converge or the problem is rank deficient.
    """
    from .diagnostics import assess

    t_start = time.perf_counter()
    observe_s = default_observation_spacing(rec) if static_block_s is None else static_block_s
    initial = initial or rough_parameters(rec)
    groups = model_groups(model)
    names = P.model_names(groups)
    reference = initial.aligned(names)
    noise_plan = plan_noise(rec, reference, noise)
    timings = {"noise from the raw data": time.perf_counter() - t_start}
    swaying = describe_motion(noise_plan.motions)
    if static_step_s is None:
        static_step_s = min(observe_s, SWAY_STATIC_STEP_S) if swaying else observe_s
    warnings = list(rec.warnings)

    built = []

    def build(names_):
        problem_ = build_problem(rec, initial.aligned(names_), observe_s, rotation_step_s, static_step_s, names_)
        built.append(problem_)
        if progress:
            progress(f"nlp: graph of {sum(len(p.step_dt) for p in problem_.groups)} steps, {problem_.n_variables} "
                     f"variables ({len(names_)} parameters), {problem_.n_residuals} residuals built in "
                     f"{problem_.build_time:.2f} s")
        return problem_

    problem = build(names)
    while len(problem.names) > P.N_PARAMS:  # extra groups the schedule cannot see are left at their prior
        dropped = unobservable_group(problem, quick_weights(problem, noise_plan.model, rec.dt, True,
                                                            noise_plan.motions))
        if dropped is None:
            break
        key, partners = dropped
        groups = tuple(g for g in groups if g != key)
        message = (f"{P.EXTRA_GROUPS[key].label} ({key}) is not observable from this schedule (one with "
                   f"{', '.join(partners)}): left at {P.EXTRA_GROUPS[key].prior:g}")
        warnings.append(message)
        if progress:
            progress(f"nlp: {message}")
        problem = build(P.model_names(groups))
    if progress and swaying:
        progress(f"nlp: {swaying}; static segments stepped at {static_step_s:g} s")
    modes = [True, False] if use_rotation_steps == "auto" else [bool(use_rotation_steps)]
    selection = None
    for mode in modes:
        if not mode:  # without the steps across rotations only the quadratic scale remains observable
            kept = tuple(g for g in P.groups_in(problem.names) if g == "quadratic")
            if P.model_names(kept) != problem.names:
                left = [g for g in P.groups_in(problem.names) if g != "quadratic"]
                warnings.append(f"without the steps across rotations {', '.join(left)} cannot be seen: left at 0")
                problem = build(P.model_names(kept))
        fit = _fit(rec, problem, noise_plan, mode, hessian, tolerance, max_iterations, progress)
        if model == "auto" and len(problem.names) > P.N_PARAMS:
            selection = select_groups(problem, fit)
            chosen = tuple(g for g in groups if selection.get(g, {}).get("selected"))
            if progress:
                progress("nlp: model selection: " + ", ".join(
                    f"{g} {v['statistic']:.3g} (threshold {v['threshold']:.3g}) "
                    f"{'kept' if v['selected'] else 'left at 0'}" for g, v in selection.items()))
            if P.model_names(chosen) != problem.names:
                problem = build(P.model_names(chosen))
                fit = _fit(rec, problem, noise_plan, mode, hessian, tolerance, max_iterations, progress)
        # steps that the model cannot explain: a 21-parameter fit of a unit with lever arms or a time offset
        # would take them for sensor errors; a model with those terms keeps the steps (any misfit left is an
        # unmodelled error, below)
        sees_steps = {"lever", "timing"} <= set(P.groups_in(problem.names))
        if mode and len(modes) > 1 and not sees_steps and fit["rotation_step_ratio"] > STEP_CONSISTENCY_LIMIT:
            message = (f"the velocity steps across rotations are {np.sqrt(fit['rotation_step_ratio']):.3g} times "
                       f"noisier than the static residuals: not explained by the {_model_label(problem.names)} "
                       "(lever arms, timing offset?); refitted without them")
            if progress:
                progress(f"nlp: {message}")
            warnings.append(message)
            continue
        break
    if swaying:
        warnings.append(f"{swaying}: the static gyro means carry the sway's variance, the navigation steps "
                        f"{static_step_s:g} s")
    timings["graph"] = sum(p_.build_time for p_ in built)
    timings["ipopt and generalised least squares"] = time.perf_counter() - t_start - sum(timings.values())
    assessment = assess(rec, problem, fit, noise_plan)
    if assessment.model_fails:
        # errors outside the model: give them a place in it (unmodelled acceleration per static segment,
        # unmodelled rate per gyro mean), with variances from the residuals, and solve again
        unmodelled = estimate_unmodelled(problem, fit, noise_plan)
        if progress:
            progress(f"nlp: residuals exceed the noise model: unmodelled acceleration "
                     f"{unmodelled.unmodelled_acceleration / UG:.3g} ug per static segment, unmodelled rate "
                     f"{unmodelled.unmodelled_rate / DEG_PER_H:.3g} deg/h per gyro mean, unmodelled step "
                     f"{unmodelled.unmodelled_step * 1e3:.3g} mm/s per rotation added")
        stats = fit["stats"]
        fit = _gls(rec, problem, noise_plan, unmodelled, fit["z"], fit["use_rotation_steps"], progress,
                   update_free=False)
        fit["stats"] = stats
        failed = [f"{c.name} {c.value:.3g} (limit {c.limit:.3g})" for c in assessment.checks if not c.passed]
        assessment = assess(rec, problem, fit, noise_plan)
        step = (f", {unmodelled.unmodelled_step * 1e3:.3g} mm/s per velocity step across a rotation"
                if fit["use_rotation_steps"] else "")
        warnings.append(f"the residuals exceeded the sensor noise ({'; '.join(failed)}): errors outside the model "
                        f"were added to it: {unmodelled.unmodelled_acceleration / UG:.3g} ug unmodelled acceleration "
                        f"per static segment, {unmodelled.unmodelled_rate / DEG_PER_H:.3g} deg/h per static gyro "
                        f"mean{step}; sigma includes them")
    warnings += assessment.warnings
    covariance_w = fit["covariance_natural"] * assessment.variance_factor
    z = fit["z"]
    names = problem.names
    n_params = len(names)
    reference = problem.reference
    values = natural_to_parameters(z[:n_params], reference, names)
    scale = natural_scale(reference, names)
    covariance = covariance_w[:n_params, :n_params] * np.outer(scale, scale)
    start_offsets = {g: z[n_params + 3 * i: n_params + 3 * i + 3] for i, g in enumerate(rec.group_ids)}
    start_attitudes = {g: small_rotation(start_offsets[g] * ARCSEC) @ problem.start_attitudes[g]
                       for g in rec.group_ids}
    noise_model = fit["noise"]
    per_sample = {"accel_noise_ug": float(np.mean(noise_model.accel_vrw)) / np.sqrt(rec.dt) / UG,
                  "gyro_noise_deg_h": float(np.mean(noise_model.gyro_arw)) / np.sqrt(rec.dt) / DEG_PER_H,
                  "velocity_white_mps": float(np.sqrt(np.mean(noise_model.accel_quantization**2)))}
    if progress:
        nat = noise_model.natural()
        progress(f"nlp: noise model: ARW {_fmt(nat['gyro_arw_deg_rth'])} deg/sqrt(h) ({noise_plan.source['gyro_arw']}), "
                 f"VRW {_fmt(nat['accel_vrw_ug_rthz'])} ug/sqrt(Hz) ({noise_plan.source['accel_vrw']}); variance "
                 f"factors velocity {assessment.factors['velocity']:.3g}, gyro {assessment.factors['gyro']:.3g}")
        for message in warnings:
            progress(f"nlp: warning: {message}")
    timings["checks and covariance"] = time.perf_counter() - t_start - sum(timings.values())
    info = {"ipopt_iterations": int(fit["stats"]["iter_count"]), "ipopt_status": fit["stats"]["return_status"],
            "timings": timings,
            "rotation_step_ratio": fit["rotation_step_ratio"], "rotation_steps_used": fit["use_rotation_steps"],
            "warnings": warnings, "checks": assessment.checks, "variance_factor": assessment.variance_factor,
            "variance_factors": assessment.factors, "build_time": problem.build_time,
            "residuals": problem.n_residuals, "start_offsets_arcsec": start_offsets,
            "start_attitudes": start_attitudes, "residual_vector": fit["whitened_residuals"],
            "residual_index": problem.residual_index, "residual_kind": problem.kind, "plans": problem.groups,
            "problem": problem, "covariance_natural": covariance_w, "hessian": hessian, "gls_steps": fit["gls_steps"],
            "noise_model": noise_model, "noise_raw": noise_plan.raw, "noise_sources": dict(noise_plan.source),
            "noise_fitted": assessment.fitted_noise, "base_motion": noise_plan.motions,
            "static_step_s": static_step_s, "observe_s": observe_s, "model": P.groups_in(names),
            "model_selection": selection, **per_sample}
    return CalibrationResult("nlp", P.ParameterSet(values, covariance=covariance, names=names), initial,
                             [reference, values], int(fit["stats"]["iter_count"]), True,
                             float(np.sqrt(np.mean(fit["whitened_residuals"] ** 2))), time.perf_counter() - t_start,
                             SIGMA_MEANING, info)


#: Extra groups dropped first when the schedule cannot separate them (the weakest-seen first).
DROP_ORDER = ("lever_along", "lever", "timing", "quadratic")


def unobservable_group(problem: Problem, weights) -> tuple[str, list[str]] | None:
    """The extra group to leave out when the Jacobian at the reference is rank deficient, with the
    variables it is confounded with; ``None`` when every variable is observable."""
    jac = weights @ np.asarray(problem.jacobian(np.zeros(problem.n_variables))[1])
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    null = s < RANK_TOLERANCE * s[0]
    if not null.any():
        return None
    involved = np.abs(vt[null]).max(axis=0) > 0.1
    names = problem.variable_names()
    present = P.groups_in([n for n, i in zip(names, involved) if i])
    for key in DROP_ORDER:
        if key in present:
            members = set(P.EXTRA_GROUPS[key].names)
            return key, [n for n, i in zip(names, involved) if i and n not in members]
    return None


def _model_label(names) -> str:
    extras = P.groups_in(names)
    return "21-parameter model" if not extras else f"model (21 + {', '.join(extras)})"


def select_groups(problem: Problem, fit: dict) -> dict[str, dict]:
    """Which extra groups the data support: each group's Wald statistic ``x^T C^-1 x`` (natural units, from
    the fit with every group) against the Bayesian information criterion ``k ln n``."""
    out = {}
    n = problem.n_residuals
    for key in P.groups_in(problem.names):
        idx = [problem.names.index(name) for name in P.EXTRA_GROUPS[key].names]
        x = fit["z"][idx]
        cov = fit["covariance_natural"][np.ix_(idx, idx)]
        statistic = float(x @ np.linalg.solve(cov, x))
        threshold = len(idx) * float(np.log(n))
        out[key] = {"statistic": statistic, "threshold": threshold, "selected": statistic > threshold,
                    "values_natural": x.tolist()}
    return out


def _fmt(values) -> str:
    return "/".join(f"{v:.3g}" for v in np.atleast_1d(values))


def _fit(rec: Recording, problem: Problem, noise_plan: NoisePlan, use_rotation_steps: bool, hessian: str,
         tolerance: float, max_iterations: int, progress) -> dict:
    """Stage 1 (Ipopt, quick weights) and stage 2 (generalised least squares under the noise model)."""
    weights = quick_weights(problem, noise_plan.model, rec.dt, use_rotation_steps, noise_plan.motions)
    z, stats = _solve_ipopt(problem, weights, hessian, tolerance, max_iterations, progress)
    if stats["return_status"] in ("User_Requested_Stop", "Interrupted_By_User"):
        raise KeyboardInterrupt  # Ctrl-C inside Ipopt: an interruption, not a failure to converge
    if not stats["success"]:
        # a rank deficiency is the likelier cause: name it
        _check_rank(np.asarray(problem.jacobian(z)[1]), problem.variable_names())
        raise CalibrationError(f"Ipopt did not converge: {stats['return_status']} "
                               f"after {stats['iter_count']} iterations")
    fit = _gls(rec, problem, noise_plan, dataclasses.replace(noise_plan.model), z, use_rotation_steps, progress)
    fit["stats"] = stats
    return fit


def _gls(rec: Recording, problem: Problem, noise_plan: NoisePlan, model: SensorNoise, z: np.ndarray,
         use_rotation_steps: bool, progress, update_free: bool = True) -> dict:
    """Gauss-Newton on the Kalman-whitened residuals from ``z`` until a step is below 1 % of a sigma."""
    gls_steps = []
    system = None
    for _ in range(GLS_MAX_STEPS):
        r, jac = (np.asarray(m) for m in problem.jacobian(z))
        r = r.ravel()
        if system is None or gls_steps[-1] > 0.3:  # the attitudes barely move once near the answer
            system = NoiseSystem(problem.tracks(np.asarray(problem.trajectory(z)), use_rotation_steps,
                                                noise_plan.motions), rec.site.g, rec.site.earth_rate)
        white = system.whiten(np.column_stack([r, jac]), model).columns
        rw, jw = white[:, 0], white[:, 1:]
        u, s, vt = np.linalg.svd(jw, full_matrices=False)
        _check_rank(jw, problem.variable_names(), (u, s, vt))
        step = -vt.T @ ((u.T @ rw) / s)
        sigma = np.sqrt(np.sum((vt.T / s) ** 2, axis=1))
        if np.max(np.abs(step) / sigma) > 1.0:  # outside the linear region a full step may overshoot
            step = _line_search(problem, system, model, z, step, float(rw @ rw))
        gls_steps.append(float(np.max(np.abs(step) / sigma)))
        z = z + step
        rw = rw + jw @ step
        if update_free and any(noise_plan.free_terms().values()):
            # the terms the raw data did not determine, once, at the first linearisation; then solve again
            model = _estimate_free_terms(model, noise_plan, system, np.column_stack([r + jac @ step, jac]))
            update_free = False
            continue
        if gls_steps[-1] < GLS_LINEAR_STEP:
            break
    if progress:
        progress("nlp: generalised least squares under the noise model, steps of "
                 + ", ".join(f"{s:.3g}" for s in gls_steps) + " sigma")
    covariance = (vt.T / s**2) @ vt
    steps = problem.row_after_rotation & (problem.kind == 0)
    plain = (problem.kind == 0) & ~steps & ~problem.row_first
    ratio = (float(np.mean(rw[steps] ** 2) / np.mean(rw[plain] ** 2))
             if use_rotation_steps and steps.any() and plain.any() else 1.0)
    return {"z": z, "noise": model, "whitened_residuals": rw, "whitened_jacobian": jw, "residuals": r + jac @ step,
            "leverage": np.sum(u**2, axis=1), "left_singular_vectors": u, "covariance_natural": covariance,
            "gls_steps": gls_steps, "rotation_step_ratio": ratio, "use_rotation_steps": use_rotation_steps,
            "system": system, "jacobian": jac}


#: Search ranges of the unmodelled terms: acceleration (m/s^2), rate (rad/s).
UNMODELLED_ACCELERATION_RANGE = (1e-8, 1e-2)
UNMODELLED_RATE_RANGE = (1e-12, 1e-5)
UNMODELLED_STEP_RANGE = (1e-7, 1.0)


def restricted_likelihood(system: NoiseSystem, columns: np.ndarray, model: SensorNoise) -> float:
    """Negative restricted log-likelihood of residuals linearised at a fit (``columns`` = [r, J]).

    The Kalman filter gives ``log det Sigma`` and the whitened columns; the parameters are profiled out
    (generalised least squares) and their degrees of freedom taken off (REML).
    """
    white = system.whiten(columns, model)
    rw, jw = white.columns[:, 0], white.columns[:, 1:]
    q, rr = np.linalg.qr(jw)
    rest = rw - q @ (q.T @ rw)
    return 0.5 * (white.log_det + float(rest @ rest)) + float(np.sum(np.log(np.abs(np.diag(rr)))))


def estimate_terms(system: NoiseSystem, columns: np.ndarray, base: SensorNoise,
                   terms: dict[str, tuple[float, float, float]]) -> SensorNoise:
    """Noise terms by restricted maximum likelihood (Nelder-Mead in log scale).

    ``terms`` maps a :class:`SensorNoise` field to ``(start, low, high)``; per-axis fields are scaled as a
    whole (their shape across axes is kept from ``base`` where it is not zero).
    """
    from scipy.optimize import minimize

    names = list(terms)
    shapes = {}
    for name in names:
        value = np.asarray(getattr(base, name), dtype=float)
        shapes[name] = value / value.max() if value.ndim and value.max() > 0 else np.ones(value.shape)

    def model_of(theta):
        out = dataclasses.replace(base)
        for name, t in zip(names, theta):
            level = float(np.exp(t))
            setattr(out, name, shapes[name] * level if np.ndim(getattr(base, name)) else level)
        return out

    start = [np.log(np.clip(terms[n][0], terms[n][1], terms[n][2])) for n in names]
    bounds = [(np.log(terms[n][1]), np.log(terms[n][2])) for n in names]
    result = minimize(lambda t: restricted_likelihood(system, columns, model_of(t)), start, method="Nelder-Mead",
                      bounds=bounds, options={"xatol": 0.03, "fatol": 0.05, "maxfev": 40 * len(names)})
    return model_of(result.x)


def estimate_unmodelled(problem: Problem, fit: dict, noise_plan: NoisePlan) -> SensorNoise:
    """Variances of the errors outside the model, by restricted maximum likelihood at the fit.

    The two terms (an acceleration constant in each static segment, a rate on each static gyro mean)
    take the share of the misfit that the data assign to them, and the relative weight of velocity and
    gyro residuals follows.
    """
    r = fit["residuals"]
    gyro = problem.kind == 1
    start_acc = np.sqrt(np.mean(r[problem.kind == 0] ** 2)) / 100.0  # a slope of the residuals' size per 100 s
    start_rate = np.sqrt(np.mean(r[gyro] ** 2)) if gyro.any() else 1e-9
    terms = {"unmodelled_acceleration": (start_acc, *UNMODELLED_ACCELERATION_RANGE),
             "unmodelled_rate": (start_rate, *UNMODELLED_RATE_RANGE)}
    if fit["use_rotation_steps"]:
        terms["unmodelled_step"] = (1e-4, *UNMODELLED_STEP_RANGE)
    return estimate_terms(fit["system"], np.column_stack([r, fit["jacobian"]]), fit["noise"], terms)


def _line_search(problem: Problem, system: NoiseSystem, model: SensorNoise, z: np.ndarray, step: np.ndarray,
                 cost: float, halvings: int = 8) -> np.ndarray:
    """The Gauss-Newton step, halved until the whitened cost does not grow (far from the linear region:
    residuals much larger than the noise model, as with unmodelled errors)."""
    for _ in range(halvings):
        if np.max(np.abs(step)) < 1e-9:
            return step
        trial = np.asarray(problem.residuals(z + step)).ravel()
        new_cost = float(np.sum(system.whiten(trial, model).columns ** 2))
        if new_cost <= cost * (1.0 + 1e-9) + 1e-12:
            return step
        step = step / 2.0
    return np.zeros_like(step)


def _estimate_free_terms(model: SensorNoise, noise_plan: NoisePlan, system: NoiseSystem,
                         columns: np.ndarray) -> SensorNoise:
    """The white-noise terms the raw data did not determine (coarse pulses hide them), by restricted
    maximum likelihood between the floors and the raw data's upper bounds; with the accelerometers'
    white noise also their quantization, which the sawtooth of coarse pulses makes only roughly white."""
    free = [t for terms in noise_plan.free_terms().values() for t in terms]
    bounds = noise_plan.raw.upper_bounds()
    ranges = {"gyro_arw": (GYRO_ARW_FLOOR, max(float(bounds.gyro_arw.max()), GYRO_ARW_FLOOR * 10)),
              "accel_vrw": (ACCEL_VRW_FLOOR, max(float(bounds.accel_vrw.max()), ACCEL_VRW_FLOOR * 10))}
    model = dataclasses.replace(model)
    for t in free:  # no shape across axes is known: one level for the three
        setattr(model, t, np.full(3, float(np.median(getattr(model, t)))))
    terms = {t: (float(np.max(getattr(model, t))), *ranges[t]) for t in free}
    if "accel_vrw" in free and np.max(model.accel_quantization) > 0:
        q = float(np.max(model.accel_quantization))
        terms["accel_quantization"] = (q, q / 10.0, q * 10.0)
    return estimate_terms(system, columns, model, terms)


def _check_rank(jac: np.ndarray, names: list[str] | None = None, svd=None) -> None:
    """Raise naming the unobservable variables when the Jacobian is (numerically) rank deficient.

    Relative singular values below :data:`RANK_TOLERANCE` count as zero: on the paper's schedule and
    the peer's 19 positions the smallest is 7e-6, on a one-group schedule 7e-9.
    """
    m, n = jac.shape
    u, s, vt = svd if svd is not None else np.linalg.svd(jac, full_matrices=False)
    null = s < RANK_TOLERANCE * s[0]
    if m <= n or null.any():
        weak = np.abs(vt[null]).max(axis=0) > 0.3 if null.any() else np.ones(n, bool)
        names = names or [P.NAMES[i] if i < P.N_PARAMS else f"start attitude of group {(i - P.N_PARAMS) // 3 + 1}"
                          for i in range(n)]
        raise CalibrationError(f"the residuals do not determine all parameters (condition "
                               f"{s[0] / max(s[-1], 1e-300):.2g}); not observable from this schedule: "
                               f"{', '.join(names[i] for i in np.flatnonzero(weak))}")


