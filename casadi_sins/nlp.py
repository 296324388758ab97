"""The CasADi/Ipopt estimator: calibration as one nonlinear least-squares problem.

Decision variables
    the 21 parameters as deviations from a reference (the starting values) in
    natural units (ug, ppm of the value, arcsec, deg/h), and per group a
    small rotation (arcsec, ENU) of the start attitude away from the coarse
    alignment: the positions' deviations from nominal are nuisance variables,
    the alignment is only the starting guess (physics pitfall 6).
Graph
    every group is navigated by the one strapdown step (:func:`strapdown.step_function`)
    chained with ``mapaccum``; the raw pulses enter through the one
    compensation expression (:func:`parameters.compensate_expr`).  In static
    segments the pulses are summed into blocks (default 1 s, 5 s for integer
    pulses: exact for the output model, and the strapdown step is exact for a
    body at rest); in rotations into 40 ms steps (the error grows as
    rate^2 x step^3: below 0.001 natural units at 40 ms, see the benchmarks).
Residuals
    the navigated velocity at the end of every static block (true velocity
    zero), as differences between consecutive observations divided by the
    square root of the samples between them.  White accelerometer noise makes
    the velocity a random walk; these differences are white and of equal
    variance (physics pitfall 7).  A difference that spans a rotation carries
    the velocity change across the rotation; ``use_rotation_steps=False``
    drops it (as a free velocity offset per static segment would), for units
    whose lever arms or timing offsets make those steps unmodelled.
Solve
    Ipopt, derivatives by algorithmic differentiation, Gauss-Newton Hessian
    ``J^T J`` (see benchmarks/bench_nlp.py for exact Hessian and L-BFGS).
Gyro residuals
    per static segment, the mean compensated gyro rate against the Earth rate
    seen in the navigated attitude.  The velocity sees gyro errors only through
    the slow attitude drift; the segment mean measures them directly, with gyro
    noise that is independent of the accelerometer noise of the velocity.
    Without them the free start attitudes cost a factor 3 in gyro scale factor.
Uncertainty
    the noise level of each residual kind is a variance component estimated
    from the fit (residual sum of squares over its degrees of freedom, pitfall
    8); then ``(J^T W J)^-1`` at the solution.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable

import casadi as ca
import numpy as np

from . import parameters as P
from .initial import rough_parameters
from .recording import Recording
from .result import CalibrationError, CalibrationResult
from .strapdown import (Q, dcm_to_quat, group_alignment, navigation_constants,
                        quat_from_rotvec, quat_multiply, step_function)
from .frames import small_rotation
from .units import ARCSEC

SIGMA_MEANING = ("1-sigma from the Gauss-Newton covariance (J^T W J)^-1 of the velocity and gyro residuals, "
                 "W from the noise levels estimated in the fit")


@dataclasses.dataclass
class GroupSteps:
    """How one group is stepped: pulse sums per step and which step ends are observed."""

    group: int
    pulses_gyro: np.ndarray  # (3, M) pulse sums per step
    pulses_accel: np.ndarray
    step_dt: np.ndarray  # (M,) step length, s
    previous_scale: np.ndarray  # (M,) 1 where the previous step has the same length, else 0
    observed: np.ndarray  # (K,) indices of steps whose end velocity is observed
    samples_between: np.ndarray  # (K,) samples between consecutive observations (first: since the start)
    after_rotation: np.ndarray  # (K,) True where the difference spans a rotation
    observed_time: np.ndarray  # (K,) time of each observation, s
    segment_of: np.ndarray  # (K,) segment number of each observation


def plan_steps(rec: Recording, group: int, static_block_s: float = 1.0, rotation_step_s: float = 0.0
               ) -> GroupSteps:
    """Split a group's samples into navigation steps (blocks in static segments and rotations)."""
    span = rec.group_samples(group)
    block = max(1, int(round(static_block_s * rec.rate_hz)))
    rotation_block = max(1, int(round(rotation_step_s * rec.rate_hz)))
    bounds: list[tuple[int, int, int | None]] = []  # (first sample, stop, static segment number or None)
    cursor = span.start
    for seg in rec.group_segments(group):
        sl = rec.segment_samples(seg)
        while cursor < sl.start:  # samples between segments: one step each
            bounds.append((cursor, cursor + 1, None))
            cursor += 1
        size = block if seg.is_static else rotation_block
        n = sl.stop - sl.start
        count = max(1, int(round(n / size)))
        edges = np.round(np.linspace(sl.start, sl.stop, count + 1)).astype(int)
        for a, b in zip(edges[:-1], edges[1:]):
            bounds.append((a, b, seg.number if seg.is_static else None))
        cursor = sl.stop
    while cursor < span.stop:
        bounds.append((cursor, cursor + 1, None))
        cursor += 1
    cum_g = np.vstack([np.zeros(3), np.cumsum(rec.gyro, axis=0)])
    cum_a = np.vstack([np.zeros(3), np.cumsum(rec.accel, axis=0)])
    first = np.array([b[0] for b in bounds])
    stop = np.array([b[1] for b in bounds])
    static_of = np.array([-1 if b[2] is None else b[2] for b in bounds])
    lengths = (stop - first).astype(float)
    observed = np.flatnonzero(static_of >= 0)
    obs_stop = stop[observed]
    between = np.diff(np.concatenate([[span.start], obs_stop]))
    seg_numbers = static_of[observed]
    spans_rotation = np.concatenate([[False], seg_numbers[1:] != seg_numbers[:-1]])
    return GroupSteps(
        group=group,
        pulses_gyro=(cum_g[stop] - cum_g[first]).T,
        pulses_accel=(cum_a[stop] - cum_a[first]).T,
        step_dt=lengths * rec.dt,
        # coning and sculling use the previous increment as a rate estimate: meaningless across a change of
        # step length (a 1 s block after a rotation sample would extrapolate the rotation into rest)
        previous_scale=(lengths == np.concatenate([[lengths[0]], lengths[:-1]])).astype(float),
        observed=observed,
        samples_between=between.astype(float),
        after_rotation=spans_rotation,
        observed_time=rec.time[obs_stop - 1],
        segment_of=seg_numbers,
    )


def natural_to_parameters(z, reference: np.ndarray):
    """Parameters (SI) from natural-unit deviations ``z`` from ``reference`` (CasADi or NumPy)."""
    ref = ca.DM(reference)
    scale = np.where(P.SCALE_MASK, reference * 1e-6, P.NATURAL_SCALE)
    return ref + ca.diag(ca.DM(scale)) @ z if isinstance(z, (ca.MX, ca.SX)) else reference + scale * np.asarray(z)


RESIDUAL_KINDS = ("velocity", "gyro")
#: Floors of the estimated noise (far below any real sensor): gyro angle random walk (deg/sqrt(h)) and
#: accelerometer velocity random walk (ug/sqrt(Hz)).  They keep noise-free data from giving one kind of
#: residual an absurd weight.
GYRO_ARW_FLOOR = 1e-6
#: Mean square of the whitened residuals that span rotations over that of the others, above which the
#: steps are taken as unmodelled (F-test: the 99.9 % point for 27 against 3500 degrees of freedom is 2.0).
STEP_CONSISTENCY_LIMIT = 3.0
RANK_TOLERANCE = 1e-7
ACCEL_VRW_FLOOR = 0.01


@dataclasses.dataclass
class Problem:
    """The built NLP: CasADi functions of the decision vector, and what they mean.

    Residuals come in two kinds with independent noise: velocity differences (accelerometer
    noise, unit ``velocity_unit`` m/s per square-root sample) and static gyro means (gyro noise,
    unit ``gyro_unit`` rad/s per square-root sample).  Their relative weights are variance
    components estimated from the fit.
    """

    residuals: ca.Function  # w -> r (in the nominal units of each kind)
    jacobian: ca.Function  # w -> (r, J)
    n_variables: int
    n_residuals: int
    kind: np.ndarray  # (m,) 0 velocity, 1 gyro
    groups: list[GroupSteps]
    reference: np.ndarray
    start_attitudes: dict[int, np.ndarray]
    velocity_unit: float
    gyro_unit: float
    build_time: float
    residual_index: list[tuple]
    chains: list[np.ndarray]  # residual indices of each run of consecutive velocity differences (group, axis)
    samples: np.ndarray  # (m,) samples spanned by each velocity difference (0 for gyro residuals)
    from_start: np.ndarray  # (m,) True for a group's first difference (velocity known zero at the start)


def static_gyro_noise(rec: Recording, params: np.ndarray, block: int = 100) -> float:
    """A first estimate of the gyro white noise per sample (rad/s), from block means in static segments.

    Over-estimates with integer pulses (quantisation adds to short blocks); the fit refines it.
    """
    from .strapdown import compensated_increments

    variances = []
    for seg in rec.static_segments:
        dtheta, _ = compensated_increments(rec, params, rec.segment_samples(seg))
        n = len(dtheta) // block
        if n < 3:
            continue
        means = dtheta[: n * block].reshape(n, block, 3).mean(axis=1) / rec.dt
        variances.append(means.var(axis=0, ddof=1).mean() * block)
    floor = GYRO_ARW_FLOOR * np.pi / 180 / 60 / np.sqrt(rec.dt)  # ARW (rad/sqrt(s)) -> per-sample rate noise
    return max(float(np.sqrt(np.mean(variances))) if variances else floor, floor)


def build_problem(rec: Recording, reference: np.ndarray, static_block_s: float = 1.0, rotation_step_s: float = 0.04,
                  use_rotation_steps: bool = True, noise_ug: float = 50.0) -> Problem:
    """Build the symbolic NLP for a recording around ``reference`` parameters."""
    from .strapdown import quat_to_dcm

    t0 = time.perf_counter()
    groups = rec.group_ids
    n_var = P.N_PARAMS + 3 * len(groups)
    w = ca.MX.sym("w", n_var)
    params = natural_to_parameters(w[: P.N_PARAMS], reference)
    earth_dt, gravity_dt = navigation_constants(rec)
    velocity_unit = noise_ug * P.UG * rec.dt  # velocity noise per sample at the nominal accelerometer noise
    gyro_unit = static_gyro_noise(rec, reference)
    parts, kinds, index, chains, spans, starts_flag = [], [], [], [], [], []
    plans, starts = [], {}
    for gi, group in enumerate(groups):
        plan = plan_steps(rec, group, static_block_s, rotation_step_s)
        plans.append(plan)
        start = group_alignment(rec, group, reference)
        starts[group] = start
        steps = len(plan.step_dt)
        dt_row = ca.DM(plan.step_dt).T
        dtheta, dv = P.compensate_expr(ca.DM(plan.pulses_gyro), ca.DM(plan.pulses_accel), params, dt_row)
        rotvec = w[P.N_PARAMS + 3 * gi: P.N_PARAMS + 3 * gi + 3] * ARCSEC
        q0 = quat_multiply(quat_from_rotvec(rotvec), ca.DM(dcm_to_quat(start)))
        x0 = ca.vertcat(q0, ca.DM.zeros(3), dtheta[:, 0], dv[:, 0])
        chain = step_function().mapaccum("strapdown_chain", steps)
        ratio = plan.step_dt[None, :] / rec.dt
        states = chain(x0, dtheta, dv, ca.DM(earth_dt[:, None] * ratio), ca.DM(gravity_dt[:, None] * ratio),
                       ca.DM(plan.previous_scale).T)
        # velocity differences between consecutive observations, whitened for a random walk
        velocity = states[4:7, list(plan.observed)]
        diffs = ca.horzcat(velocity[:, 0], velocity[:, 1:] - velocity[:, :-1])
        keep = np.ones(len(plan.observed), bool) if use_rotation_steps else ~plan.after_rotation
        weights = 1.0 / (np.sqrt(plan.samples_between) * velocity_unit)
        cols = list(np.flatnonzero(keep))
        parts.append(ca.vec(diffs[:, cols] @ ca.diag(ca.DM(weights[cols]))))
        base = len(kinds)
        kinds += [0] * (3 * len(cols))
        index += [(group, "rotation step" if plan.after_rotation[k] else "velocity", int(k), axis)
                  for k in cols for axis in range(3)]
        spans += [plan.samples_between[k] for k in cols for _ in range(3)]
        starts_flag += [k == 0 for k in cols for _ in range(3)]
        # consecutive differences share the white (quantisation) noise of the velocity between them
        runs = np.split(np.arange(len(cols)), np.flatnonzero(np.diff(cols) != 1) + 1)
        chains += [base + 3 * run + axis for run in runs for axis in range(3)]
        # mean gyro rate of each static segment against the Earth rate seen in the navigated attitude
        for seg_number in np.unique(plan.segment_of):
            cols_seg = plan.observed[plan.segment_of == seg_number]
            duration = float(plan.step_dt[cols_seg].sum())
            n_samples = duration / rec.dt
            mean_rate = ca.sum2(dtheta[:, list(cols_seg)]) / duration
            mid = int(cols_seg[len(cols_seg) // 2])
            earth_in_body = quat_to_dcm(states[Q, mid]).T @ ca.DM(rec.site.earth_rate)
            parts.append((mean_rate - earth_in_body) * (np.sqrt(n_samples) / gyro_unit))
            kinds += [1] * 3
            index += [(group, "gyro", int(seg_number), axis) for axis in range(3)]
            spans += [0.0] * 3
            starts_flag += [False] * 3
    r = ca.vertcat(*parts)
    residuals = ca.Function("residuals", [w], [r])
    jacobian = ca.Function("residuals_jacobian", [w], [r, ca.jacobian(r, w)])
    return Problem(residuals, jacobian, n_var, r.shape[0], np.array(kinds), plans, reference, starts,
                   velocity_unit, gyro_unit, time.perf_counter() - t0, index, chains, np.array(spans),
                   np.array(starts_flag))


def _solve_ipopt(problem: Problem, hessian: str, tolerance: float, max_iterations: int,
                 progress: Callable[[str], None] | None, kind_weights: np.ndarray):
    w = ca.MX.sym("w", problem.n_variables)
    r = problem.residuals(w) * ca.DM(kind_weights[problem.kind])
    weight = 1.0 / problem.n_residuals  # mean square: the tolerance does not depend on the recording's length
    nlp = {"x": w, "f": 0.5 * weight * ca.dot(r, r)}
    # The variables are in natural units already: Ipopt's gradient scaling at the (far-off) rough start
    # would shrink the objective by ~1e-6 and stall the line search at round-off.  The gradient of the
    # chained navigation has a round-off floor near 1e-8; a gradient of 1e-7 moves the estimate by
    # ~1e-4 of its sigma.
    # Also stop when the objective stalls: with noise-free data or very unequal weights the gradient's
    # round-off floor can exceed any fixed tolerance although Gauss-Newton has converged.
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": tolerance,
            "ipopt.acceptable_tol": 1e20, "ipopt.acceptable_obj_change_tol": 1e-12, "ipopt.acceptable_iter": 2,
            "ipopt.max_iter": max_iterations, "ipopt.sb": "yes", "ipopt.nlp_scaling_method": "none"}
    if hessian == "gauss-newton":
        _, jac = problem.jacobian(w)
        jac = ca.diag(ca.DM(kind_weights[problem.kind])) @ jac
        sigma = ca.MX.sym("sigma")
        opts["hess_lag"] = ca.Function("nlp_hess_l", [w, ca.MX.sym("p", 0, 1), sigma, ca.MX.sym("lam_g", 0, 1)],
                                       [sigma * weight * ca.triu(jac.T @ jac)], ["x", "p", "lam_f", "lam_g"],
                                       ["triu_hess_gamma_x_x"])
    elif hessian == "limited-memory":
        opts["ipopt.hessian_approximation"] = "limited-memory"
    elif hessian != "exact":
        raise ValueError(f"unknown hessian {hessian!r}")
    solver = ca.nlpsol("calibration", "ipopt", nlp, opts)
    sol = solver(x0=np.zeros(problem.n_variables))
    stats = solver.stats()
    if progress:
        progress(f"nlp: ipopt {stats['return_status']} after {stats['iter_count']} iterations, "
                 f"cost {float(sol['f']):.6g}")
    return np.asarray(sol["x"]).ravel(), stats


@dataclasses.dataclass
class NoiseModel:
    """Noise of the residuals, in their nominal units.

    Velocity: a random walk of variance ``random_walk`` per sample (white accelerometer noise) plus
    white noise of variance ``white`` on every observed velocity (integer pulse counters, pitfall 8);
    consecutive differences then share the white part (covariance ``-white``).  Gyro residuals:
    variance ``gyro`` per sample.
    """

    random_walk: float = 1.0
    white: float = 0.0
    gyro: float = 1.0

    def whitener(self, problem: Problem) -> Callable[[np.ndarray], np.ndarray]:
        """A function applying ``Sigma^-1/2`` to residual vectors or Jacobians (rows = residuals)."""
        n = problem.samples
        factors = []
        for chain in problem.chains:
            # residual r_i = d_i / sqrt(n_i): Var = rw + white (2 or 1) / n_i, Cov(i, i+1) = -white / sqrt(n_i n_j)
            ni = n[chain]
            diag = self.random_walk + self.white * np.where(problem.from_start[chain], 1.0, 2.0) / ni
            cov = np.diag(diag)
            if len(chain) > 1 and self.white > 0:
                off = -self.white / np.sqrt(ni[:-1] * ni[1:])
                cov += np.diag(off, 1) + np.diag(off, -1)
            factors.append((chain, np.linalg.cholesky(cov)))
        gyro = problem.kind == 1
        gyro_scale = 1.0 / np.sqrt(self.gyro)

        def apply(x: np.ndarray) -> np.ndarray:
            out = np.array(x, dtype=float, copy=True)
            for chain, chol in factors:
                out[chain] = np.linalg.solve(chol, x[chain])
            out[gyro] = x[gyro] * gyro_scale
            return out

        return apply


def estimate_noise(r: np.ndarray, jac: np.ndarray, problem: Problem, floors: NoiseModel, rounds: int = 6
                   ) -> tuple[np.ndarray, NoiseModel]:
    """Estimate the noise model from the fit and move to its generalised least-squares optimum.

    Velocity: random-walk and white variances from the lag-0 and lag-1 moments of consecutive
    residuals; gyro: residual sum of squares over its degrees of freedom (count less its share of
    the hat matrix).  Each round takes a Gauss-Newton step with the current model from the solution
    (the model is linear there).  Returns the step in the variables and the model.
    """
    model = NoiseModel()
    step = np.zeros(jac.shape[1])
    gyro = problem.kind == 1
    for _ in range(rounds):
        whiten = model.whitener(problem)
        jw, rw = whiten(jac), whiten(r)
        u, s, vt = np.linalg.svd(jw, full_matrices=False)
        step = -vt.T @ ((u.T @ rw) / s)
        res = r + jac @ step
        # lag 0: E[r_i^2] = rw + white * (2 or 1) / n_i;  lag 1: E[r_i r_j] = -white / sqrt(n_i n_j)
        lag0 = np.concatenate([res[c] ** 2 for c in problem.chains])
        inv_n = np.concatenate([np.where(problem.from_start[c], 1.0, 2.0) / problem.samples[c]
                                for c in problem.chains])
        lag1 = np.concatenate([res[c][:-1] * res[c][1:] * np.sqrt(problem.samples[c][:-1] * problem.samples[c][1:])
                               for c in problem.chains])
        white = max(-float(np.mean(lag1)), 0.0) if lag1.size else 0.0
        random_walk = max(float(np.mean(lag0) - white * np.mean(inv_n)), floors.random_walk)
        leverage = np.sum(u**2, axis=1)
        dof = gyro.sum() - leverage[gyro].sum()
        gyro_var = (max(float(np.sum((res[gyro] / np.sqrt(model.gyro)) ** 2) / dof) * model.gyro, floors.gyro)
                    if gyro.any() and dof > 0.5 else model.gyro)
        new = NoiseModel(random_walk, max(white, floors.white), gyro_var)
        if np.allclose([new.random_walk, new.white, new.gyro], [model.random_walk, model.white, model.gyro],
                       rtol=1e-3, atol=1e-12):
            model = new
            break
        model = new
    return step, model


def default_static_block(rec: Recording) -> float:
    """Seconds per static observation: 1 s, or 5 s for integer pulse counters.

    Integer pulses add a white velocity noise of about one pulse to every observation (pitfall 8),
    far from white when the pulse is much larger than the sensor noise; over 5 s blocks the random
    walk of the accelerometer noise dominates it again, and a static base loses nothing by it.
    """
    integral = np.all(rec.accel == np.round(rec.accel)) and np.all(rec.gyro == np.round(rec.gyro))
    return 5.0 if integral else 1.0


def calibrate_nlp(rec: Recording, initial: P.ParameterSet | None = None, hessian: str = "gauss-newton",
                  static_block_s: float | None = None, rotation_step_s: float = 0.04,
                  use_rotation_steps: bool | str = "auto",
                  tolerance: float = 1e-7, max_iterations: int = 100,
                  progress: Callable[[str], None] | None = None) -> CalibrationResult:
    """Calibrate a recording by nonlinear least squares over all rotations (CasADi + Ipopt).

    Parameters
    ----------
    rec : Recording
    initial : ParameterSet, optional
        Starting values and reference of the natural-unit variables; default the rough values.
    hessian : {"gauss-newton", "exact", "limited-memory"}
    static_block_s, rotation_step_s : float
        Step lengths: static blocks (default :func:`default_static_block`) and rotation steps (40 ms:
        a method error below 0.001 natural units on the paper's problem, see benchmarks/bench_nlp.py;
        the number of steps, hence the time, does not grow with the sample rate).
    use_rotation_steps : bool or "auto"
        Keep the velocity differences that span rotations.  ``"auto"`` keeps them unless they
        disagree with the static residuals (F-test, :data:`STEP_CONSISTENCY_LIMIT`): lever arms or
        timing offsets of a real unit make velocity steps that the 21 parameters cannot explain.
    tolerance : float
        Ipopt's tolerance on the gradient of the mean square whitened residual (natural units).

    Raises
    ------
    CalibrationError
        Ipopt fails to converge or the problem is rank deficient.
    """
    t_start = time.perf_counter()
    if static_block_s is None:
        static_block_s = default_static_block(rec)
    if use_rotation_steps == "auto":
        result = calibrate_nlp(rec, initial, hessian, static_block_s, rotation_step_s, True, tolerance,
                               max_iterations, progress)
        ratio = result.info["rotation_step_ratio"]
        if ratio <= STEP_CONSISTENCY_LIMIT:
            return result
        message = (f"the velocity steps across rotations are {np.sqrt(ratio):.3g} times noisier than the static "
                   "residuals: not explained by the 21-parameter model (lever arms, timing offset?); "
                   "refitted without them")
        if progress:
            progress(f"nlp: {message}")
        refit = calibrate_nlp(rec, initial, hessian, static_block_s, rotation_step_s, False, tolerance,
                              max_iterations, progress)
        refit.info["warnings"] = refit.info.get("warnings", []) + [message]
        refit.wall_time = time.perf_counter() - t_start
        return refit
    initial = initial or rough_parameters(rec)
    reference = initial.values.copy()
    problem = build_problem(rec, reference, static_block_s, rotation_step_s, use_rotation_steps)
    if progress:
        progress(f"nlp: graph of {sum(len(p.step_dt) for p in problem.groups)} steps, {problem.n_variables} "
                 f"variables, {problem.n_residuals} residuals built in {problem.build_time:.2f} s")
    z, stats = _solve_ipopt(problem, hessian, tolerance, max_iterations, progress, np.ones(len(RESIDUAL_KINDS)))
    if not stats["success"]:
        _check_rank(np.asarray(problem.jacobian(z)[1]))  # a rank deficiency is the likelier cause: name it
        raise CalibrationError(f"Ipopt did not converge: {stats['return_status']} "
                               f"after {stats['iter_count']} iterations")
    r, jac = (np.asarray(m) for m in problem.jacobian(z))
    _check_rank(jac)
    floors = NoiseModel((ACCEL_VRW_FLOOR * P.UG * np.sqrt(rec.dt) / problem.velocity_unit) ** 2, 0.0,
                        (GYRO_ARW_FLOOR * np.pi / 180 / 60 / np.sqrt(rec.dt) / problem.gyro_unit) ** 2)
    step, noise = estimate_noise(r.ravel(), jac, problem, floors)
    # the reweighting step is a fraction of a sigma, where the model is linear: update r, keep J
    z = z + step
    r = r.ravel() + jac @ step
    whiten = noise.whitener(problem)
    rw = whiten(r)
    covariance_w, rms = _covariance(whiten(jac), rw)
    values = natural_to_parameters(z[: P.N_PARAMS], reference)
    scale = np.where(P.SCALE_MASK, reference * 1e-6, P.NATURAL_SCALE)  # d(params)/dz
    covariance = covariance_w[: P.N_PARAMS, : P.N_PARAMS] * np.outer(scale, scale)
    start_offsets = {g: z[P.N_PARAMS + 3 * i: P.N_PARAMS + 3 * i + 3] for i, g in enumerate(rec.group_ids)}
    start_attitudes = {g: small_rotation(start_offsets[g] * ARCSEC) @ problem.start_attitudes[g]
                       for g in rec.group_ids}
    pulse_white = np.sqrt(noise.white) * problem.velocity_unit  # m/s, white velocity noise per observation
    noise = {"accel_noise_ug": np.sqrt(noise.random_walk) * problem.velocity_unit / (P.UG * rec.dt),
             "gyro_noise_deg_h": np.sqrt(noise.gyro) * problem.gyro_unit / (np.pi / 180 / 3600),
             "velocity_white_mps": pulse_white}
    if progress:
        progress(f"nlp: noise from the fit: accelerometers {noise['accel_noise_ug']:.3g} ug, "
                 f"gyros {noise['gyro_noise_deg_h']:.3g} deg/h per sample, white velocity noise "
                 f"{noise['velocity_white_mps']:.3g} m/s (pulse quantisation)")
    steps = np.array([kind == "rotation step" for _, kind, _, _ in problem.residual_index])
    plain = (problem.kind == 0) & ~steps
    ratio = (float(np.mean(rw[steps] ** 2) / np.mean(rw[plain] ** 2))
             if steps.any() and plain.any() else 1.0)
    info = {"ipopt_iterations": int(stats["iter_count"]), "rotation_step_ratio": ratio,
            "rotation_steps_used": bool(use_rotation_steps), "warnings": [], "build_time": problem.build_time,
            "residuals": problem.n_residuals, "start_offsets_arcsec": start_offsets,
            "start_attitudes": start_attitudes, "residual_vector": rw,
            "residual_index": problem.residual_index, "residual_kind": problem.kind, "plans": problem.groups,
            "covariance_natural": covariance_w, "hessian": hessian, **noise}
    return CalibrationResult("nlp", P.ParameterSet(values, covariance=covariance), initial,
                             [reference, values], int(stats["iter_count"]), True, rms,
                             time.perf_counter() - t_start, SIGMA_MEANING, info)


def _check_rank(jac: np.ndarray) -> None:
    """Raise naming the unobservable variables when the Jacobian is (numerically) rank deficient.

    Relative singular values below :data:`RANK_TOLERANCE` count as zero: on the paper's schedule and
    the peer's 19 positions the smallest is 7e-6, on a one-group schedule 7e-9.
    """
    m, n = jac.shape
    u, s, vt = np.linalg.svd(jac, full_matrices=False)
    null = s < RANK_TOLERANCE * s[0]
    if m <= n or null.any():
        weak = np.abs(vt[null]).max(axis=0) > 0.3 if null.any() else np.ones(n, bool)
        names = [P.NAMES[i] if i < P.N_PARAMS else f"start attitude of group {(i - P.N_PARAMS) // 3 + 1}"
                 for i in np.flatnonzero(weak)]
        raise CalibrationError(f"the residuals do not determine all parameters (condition "
                               f"{s[0] / max(s[-1], 1e-300):.2g}); not observable from this schedule: "
                               f"{', '.join(names)}")


def _covariance(jac: np.ndarray, r: np.ndarray):
    """``s^2 (J^T J)^-1`` of whitened residuals, ``s^2`` their variance per degree of freedom."""
    m, n = jac.shape
    u, s, vt = np.linalg.svd(jac, full_matrices=False)
    variance = float(r @ r) / (m - n)
    return (vt.T / s**2) @ vt * variance, float(np.sqrt(variance))
