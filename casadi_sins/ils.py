"""The paper's reference solver: iterative linear least squares (Kang et al. 2013, section 1).

Each iteration:

1. navigate every group from its coarse alignment (eq. 14) with the current
   parameters;
2. in the static segment after each rotation, fit the north and east
   velocity errors with ``a + b tau + c tau^2`` and the up velocity error with
   ``a + b tau`` (``tau`` from the start of the segment); the linear and
   quadratic coefficients (north quadratic optional) are the equations,
   5 per rotation, 45 for the paper's 9 rotations; by default also the slope
   of the up velocity in each group's alignment segment, which the paper
   leaves unused (48 equations; ``paper_equations=True`` for exactly 45);
3. the same fits applied to the sensitivities of the velocity error to the
   21 error terms (``T_g, eps, T_a, Delta``), propagated through the linear
   error model (eqs. 13-21) along the navigated attitude with the alignment
   errors of eq. 15 (:mod:`errormodel`), give the design matrix;
4. weighted least squares for the 21 errors, then the output model is
   corrected with eqs. 22-25, and the whole is repeated until every
   correction is below ``tolerance`` times its own sigma, or below
   :data:`ABSOLUTE_TOLERANCE` in natural units.

Weights: the noise of the equations is correlated across segments (the gyro noise tilts the whole
group's navigation, the coarse alignment carries the noise of its segment into every later one, bias
instability ties the recording together).  Their covariance under the sensor noise model (measured
in the raw data, :mod:`noise`; the state-space model of :mod:`kalman`) weights a generalised least
squares, and ``sigma`` is its formal standard error, inflated by the residual variance factor only
when that exceeds its chi-square limit (48 - 21 = 27 degrees of freedom for the paper's schedule).
On a swaying base the method refuses: the coarse alignment assumes a still one.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable

import numpy as np

from . import parameters as P
from .errormodel import velocity_sensitivity
from .initial import rough_parameters
from .noise import SensorNoise, describe_motion, plan_noise
from .recording import Recording
from .result import CalibrationError, CalibrationResult
from .strapdown import navigate_group

#: Corrections below these (natural units: ug, ppm, arcsec, deg/h) end the iteration regardless of sigma.
ABSOLUTE_TOLERANCE = np.where(
    np.isin(np.array(P.NATURAL_UNITS), ["deg/h"]), 1e-5, 1e-3
)

#: The longest group the ILS takes: it holds per-sample sensitivities (21 per axis) and navigation states.
MAX_GROUP_SAMPLES = 1_500_000

SIGMA_MEANING = ("1-sigma of the generalised least squares of the last iteration, the equations' covariance "
                 "from the sensor noise model (raw-data estimate or datasheet), times the variance factor when "
                 "the residuals exceed it")


def _coefficient_operator(tau: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows mapping a velocity series at times ``tau`` (s since the segment began) to its polynomial
    slope/curvature, and their covariance under a unit random walk.

    Returns ``(rows, cov)``: ``rows`` (degree, n) gives (b, c) of ``a + b tau + c tau^2``
    (SI: m/s^2, m/s^3); ``cov`` is their covariance for a unit-intensity random walk (variance ``tau``
    m^2/s^2 at ``tau`` seconds).
    """
    tau = np.asarray(tau, dtype=float)
    scale = tau[-1]
    vander = np.vander(tau / scale, degree + 1, increasing=True)
    pinv = np.linalg.pinv(vander)[1:] / scale ** np.arange(1, degree + 1)[:, None]
    # cov = pinv Sigma pinv^T with Sigma_ij = min(tau_i, tau_j), in O(n):
    # (Sigma p)_i = sum_{j<i} tau_j p_j + tau_i sum_{j>=i} p_j
    head = np.cumsum(tau * pinv, axis=1) - tau * pinv
    tail = np.cumsum(pinv[:, ::-1], axis=1)[:, ::-1]
    sigma_p = head + tau * tail
    cov = pinv @ sigma_p.T
    return pinv, cov


@dataclasses.dataclass(frozen=True)
class Equation:
    """What one equation is: the fitted coefficient of one velocity axis in one static segment."""

    group: int
    segment: int  # segment number
    axis: int  # 0 E, 1 N, 2 U
    order: int  # 1 slope, 2 curvature

    @property
    def label(self) -> str:
        return f"segment {self.segment} v_{'ENU'[self.axis]} {['slope', 'curvature'][self.order - 1]}"


def build_equations(rec: Recording, params: np.ndarray, north_quadratic: bool = True,
                    alignment_up: bool = True):
    """The paper's equations for the current parameters: ``(A, b, equations, navigations)``.

    ``alignment_up`` adds the slope of the up velocity in each group's first (alignment) static
    segment: the alignment takes only the tilt from it, and without it a schedule whose other
    positions never turn an accelerometer up (the paper's y axis) separates its bias and scale
    factor poorly.

    ``A`` (m, 21) maps the error terms (SI, ordered like :data:`parameters.NAMES`) to the fitted
    coefficients, ``b`` (m,) are the coefficients of the navigated velocity (SI).
    """
    rows, rhs, equations, navs = [], [], [], []
    for group in rec.group_ids:
        nav = navigate_group(rec, group, params)
        navs.append(nav)
        sens = velocity_sensitivity(rec, nav, params)
        for seg, axes in equation_segments(rec, group, alignment_up):
            sl = rec.segment_samples(seg)
            local = slice(sl.start - nav.samples.start, sl.stop - nav.samples.start)
            n = local.stop - local.start
            tau = (np.arange(n) + 1) * rec.dt
            before = local.start - 1
            for axis in axes:
                degree = 1 if axis == 2 else 2
                ops, _ = _coefficient_operator(tau, degree)
                if axis == 1 and not north_quadratic:
                    ops = ops[:1]
                velocity = nav.velocity[local, axis] - (nav.velocity[before, axis] if before >= 0 else 0.0)
                sensitivity = sens[local, axis, :] - (sens[before, axis, :] if before >= 0 else 0.0)
                rows.append(ops @ sensitivity)
                rhs.append(ops @ velocity)
                equations += [Equation(group, seg.number, axis, k + 1) for k in range(len(ops))]
    return np.vstack(rows), np.concatenate(rhs), equations, navs


def equation_segments(rec: Recording, group: int, alignment_up: bool):
    """``(segment, axes)`` of a group's equations: the static segments after each rotation (E, N, U),
    and the alignment segment's up axis."""
    segs = rec.group_segments(group)
    out = [(segs[0], (2,))] if alignment_up else []
    return out + [(seg, (0, 1, 2)) for seg in segs[2::2]]


def equation_covariance(rec: Recording, params: np.ndarray, navs, equations: list[Equation],
                        noise: SensorNoise, north_quadratic: bool = True, samples: int = 3000,
                        seed: int = 0) -> np.ndarray:
    """Covariance of the equations' right-hand sides under the sensor noise model.

    The noise of the fitted coefficients is not independent between segments: the gyro noise tilts
    the whole group's navigation (angle random walk), bias instability ties the recording together,
    and the coarse alignment carries the noise of its own segment into every later one.  The
    state-space model of :mod:`kalman` (the same discretisation the NLP whitens with) is sampled along
    each group's navigated attitude at 1 s in static segments (a linear Monte Carlo of ``samples``
    draws, vectorised), the alignment error follows from the noise of the first segment through the
    linearised alignment (eq. 15), and the polynomial fits turn the velocities into coefficients.
    """
    from .errormodel import _alignment_jacobian
    from .kalman import ACC, DV, PHI, Layout, NoiseSystem
    from .nlp import ROTATION_STEP_S, group_track, plan_steps

    rng = np.random.default_rng(seed)
    model = noise.complete()
    layout = Layout.of(model)
    markov, n = layout.markov, layout.n
    by_group: dict[int, list[int]] = {}
    for i, eq in enumerate(equations):
        by_group.setdefault(eq.group, []).append(i)
    draws = np.zeros((len(equations), samples))
    carried = None  # (state draws, end time) of the previous group
    for nav in navs:
        plan = plan_steps(rec, nav.group, 1.0, ROTATION_STEP_S)
        stops = np.cumsum(np.round(plan.step_dt / rec.dt).astype(int)) - 1
        quats = nav.quaternion[stops].T
        track = group_track(plan, {}, nav.initial_attitude, quats, True)
        system = NoiseSystem([track], rec.site.g, rec.site.earth_rate)
        phi, q = system.transitions(track, model, layout)
        x = np.zeros((n, samples))
        if markov:  # the biases wander on from the previous group (one process over the recording)
            start = float(plan.start_time)
            for sl, sigma, tau in ((layout.bg, model.gyro_bias_instability, model.gyro_bias_tau),
                                   (layout.ba, model.accel_bias_instability, model.accel_bias_tau)):
                beta = np.exp(-max(start - carried[1], 0.0) / tau) if carried else 0.0
                previous = carried[0][sl] if carried else 0.0
                x[sl] = beta * previous + rng.standard_normal((3, samples)) * sigma * np.sqrt(1.0 - beta**2)
        response = np.zeros((n, 3))  # the state's response to an initial attitude error
        response[PHI] = np.eye(3)
        velocity = np.zeros((len(plan.step_dt), 3, samples))
        v_align = np.zeros((len(plan.step_dt), 3, 3))
        first_seg = rec.group_segments(nav.group)[0].number
        f_cross_phi = np.zeros((3, samples))
        gyro_sum = None
        static = plan.step_segment >= 0
        phi_run, q_run = np.eye(n), np.zeros((n, n))  # steps outside static segments, composed
        for k in range(len(plan.step_dt)):
            if not static[k]:
                phi_run = phi[k] @ phi_run
                q_run = phi[k] @ q_run @ phi[k].T + q[k]
                continue
            if q_run.any():  # the rotation before this static step
                x = phi_run @ x + _psd_sqrt(q_run) @ rng.standard_normal((n, samples))
                response = phi_run @ response
                phi_run, q_run = np.eye(n), np.zeros((n, n))
            if plan.segment_start[k]:
                x[ACC] = 0.0
            previous_phi = x[PHI].copy()
            x = phi[k] @ x + _psd_sqrt(q[k]) @ rng.standard_normal((n, samples))
            response = phi[k] @ response
            velocity[k] = x[DV]
            v_align[k] = response[DV]
            if plan.step_segment[k] == first_seg:
                f_cross_phi += system.f_cross @ (0.5 * (previous_phi + x[PHI])) * plan.step_dt[k]
                last_first = k
                gyro_sum = x[ACC].copy()
        # the alignment (eq. 14) sees the first segment's mean noise: f_noise = C^T (dv - int f x phi) / T
        duration = float(plan.step_dt[plan.step_segment == first_seg].sum())
        c1 = track.attitude[last_first]
        accel_mean = c1.T @ (velocity[last_first] - f_cross_phi) / duration
        gyro_mean = gyro_sum / duration
        first = rec.segment_samples(rec.group_segments(nav.group)[0])
        dth, dvel = P.compensate(rec.gyro[first], rec.accel[first], params, rec.dt)
        dcm, jac = (np.asarray(m) for m in _alignment_jacobian()(dvel.mean(axis=0) / rec.dt,
                                                                  dth.mean(axis=0) / rec.dt))
        d_dcm = (jac @ np.vstack([accel_mean, gyro_mean])).reshape(3, 3, samples, order="F")
        phi_cross = -np.einsum("ijs,kj->iks", d_dcm, dcm)  # [phi x] = -dC C^T
        phi0 = np.stack([phi_cross[2, 1], phi_cross[0, 2], phi_cross[1, 0]])
        total = velocity + np.einsum("kij,js->kis", v_align, phi0)
        carried = (x.copy(), float(plan.start_time + plan.step_dt.sum()))
        rows = by_group.get(nav.group, [])
        for seg, axes in equation_segments(rec, nav.group, any(equations[i].segment == first_seg for i in rows)):
            steps = np.flatnonzero(plan.step_segment == seg.number)
            tau = np.cumsum(plan.step_dt[steps])
            before = total[steps[0] - 1] if steps[0] > 0 else np.zeros((3, samples))
            for axis in axes:
                ops, _ = _coefficient_operator(tau, 1 if axis == 2 else 2)
                if axis == 1 and not north_quadratic:
                    ops = ops[:1]
                coefficients = ops @ (total[steps, axis] - before[axis])
                for order in range(len(ops)):
                    i = next(i for i in rows if equations[i] == Equation(nav.group, seg.number, axis, order + 1))
                    draws[i] = coefficients[order]
    return np.cov(draws)


def _psd_sqrt(q: np.ndarray) -> np.ndarray:
    """A square root ``L L^T = Q`` of a positive semi-definite matrix (eigen-decomposition: Q may be singular)."""
    w, v = np.linalg.eigh(0.5 * (q + q.T))
    return v * np.sqrt(np.clip(w, 0.0, None))


def solve_equations(a: np.ndarray, b: np.ndarray, covariance: np.ndarray):
    """Generalised least squares for the 21 error terms in natural scaling; raises on rank deficiency.

    Returns ``(x, covariance, variance_factor)`` in SI (scale factors relative): the formal covariance
    of the estimate under the equations' ``covariance``, and the residual chi-square per degree of
    freedom (1 when the noise model fits).
    """
    whiten = np.linalg.inv(np.linalg.cholesky(covariance))
    scaled = whiten @ a * P.NATURAL_SCALE
    b = whiten @ b
    m = len(b)
    u, s, vt = np.linalg.svd(scaled, full_matrices=False)
    if m < P.N_PARAMS or s[-1] < 1e-9 * s[0]:
        weak = np.abs(vt[-1]) > 0.3 if m >= P.N_PARAMS else np.ones(P.N_PARAMS, bool)
        names = ", ".join(np.array(P.NAMES)[weak])
        raise CalibrationError(f"the {m} equations do not determine all 21 parameters "
                               f"(condition {s[0] / max(s[-1], 1e-300):.2g}); not observable from this "
                               f"schedule: {names}")
    x_nat = vt.T @ ((u.T @ b) / s)
    residual = b - scaled @ x_nat
    dof = max(m - P.N_PARAMS, 1)
    cov_nat = (vt.T / s**2) @ vt
    scale = P.NATURAL_SCALE
    return x_nat * scale, cov_nat * np.outer(scale, scale), float(residual @ residual) / dof


def calibrate_ils(rec: Recording, initial: P.ParameterSet | None = None, max_iterations: int = 10,
                  tolerance: float = 0.01, north_quadratic: bool = True, paper_equations: bool = False,
                  progress: Callable[[str], None] | None = None, noise: SensorNoise | None = None,
                  allow_base_motion: bool = False, model: str = "21") -> CalibrationResult:
    """Calibrate a recording with the paper's iterative least squares.

    Parameters
    ----------
    rec : Recording
    initial : ParameterSet, optional
        Starting values; default the paper's rough initial values (section 1.3).
    max_iterations : int
    tolerance : float
        Stop when every correction is below ``tolerance`` times its sigma.
    north_quadratic : bool
        Use the north quadratic term (the paper allows leaving it out).
    paper_equations : bool
        Exactly the paper's 5 equations per rotation; by default the up-velocity slope of each
        group's alignment segment is added (see :func:`build_equations`).
    progress : callable, optional
        Receives one line per iteration.
    noise : SensorNoise, optional
        Datasheet noise terms; the others are measured in the raw data (:func:`noise.plan_noise`).
    allow_base_motion : bool
        Calibrate although the base sways (the result is then unreliable: see below).
    model : "21"
        The ILS fits the paper's 21 parameters only: its equations are slopes and curvatures of the
        static velocity, which do not see the steps across rotations where lever arms and a time
        offset act; the extra terms need the NLP (``model="extended"`` or ``"auto"``).

    Raises
    ------
    CalibrationError
        When the base sways (the paper's coarse alignment needs a still base: a sway of 20 arcsec
        turns the aligned heading by degrees and tilts it by the sway's amplitude, which the method
        takes for sensor errors), the equations are rank deficient or the iteration does not converge.
    """
    from .diagnostics import factor_limit

    if model not in ("21", None, ()):
        raise CalibrationError("the ILS (the paper's method) fits the 21 parameters only: its slopes and curvatures "
                               "of the static velocity do not see the velocity steps across rotations where lever "
                               "arms and a time offset act; use the nlp solver for the extended model")
    longest = max(rec.group_samples(g).stop - rec.group_samples(g).start for g in rec.group_ids)
    if longest > MAX_GROUP_SAMPLES:
        raise CalibrationError(f"a group of {longest} samples: the ILS keeps the error model's sensitivities of every "
                               f"sample (about 5 kB each), more than {MAX_GROUP_SAMPLES} samples would need "
                               f"{longest * 5e3 / 1e9:.0f} GB; the nlp solver handles long files")
    t_start = time.perf_counter()
    initial = initial or rough_parameters(rec)
    params = initial.core.copy()
    noise_plan = plan_noise(rec, params, noise)
    motion = describe_motion(noise_plan.motions)
    warnings = list(rec.warnings)
    if motion:
        if not allow_base_motion:
            raise CalibrationError(f"{motion}; the paper's method aligns each group on a still base and would "
                                   "take the sway for sensor errors: use the nlp solver, which estimates the "
                                   "start attitudes and models the sway")
        warnings.append(f"{motion}: the paper's method assumes a still base; this table is unreliable")
    history = [params.copy()]
    corrections = []
    converged = False
    covariance = None
    for iteration in range(1, max_iterations + 1):
        a, b, equations, navs = build_equations(rec, params, north_quadratic, alignment_up=not paper_equations)
        if covariance is None:  # the attitudes barely change between iterations
            covariance = equation_covariance(rec, params, navs, equations, noise_plan.model, north_quadratic)
        x, cov, factor = solve_equations(a, b, covariance)
        params = P.apply_error_estimate(params, x)
        history.append(params.copy())
        sigma = np.sqrt(np.diag(cov))
        ratio = np.abs(x) / np.where(sigma > 0, sigma, np.inf)
        small = (ratio < tolerance) | (np.abs(x) / P.NATURAL_SCALE < ABSOLUTE_TOLERANCE)
        corrections.append(x / P.NATURAL_SCALE)
        if progress:
            worst = int(np.argmax(ratio))
            progress(f"ils iteration {iteration}: {len(b)} equations, largest correction "
                     f"{P.NAMES[worst]} {x[worst] / P.NATURAL_SCALE[worst]:+.4g} {P.NATURAL_UNITS[worst]} "
                     f"({ratio[worst]:.3g} sigma), variance factor {factor:.3g}")
        if not np.all(np.isfinite(params)):
            raise CalibrationError(f"iteration {iteration} produced non-finite parameters")
        if np.all(small):
            converged = True
            break
    if not converged:
        raise CalibrationError(f"the iterative least squares did not converge in {max_iterations} iterations "
                               f"(last corrections up to {np.max(ratio):.3g} sigma)")
    dof = len(b) - P.N_PARAMS
    inflate = 1.0
    # white noise the raw data could not show (coarse pulses) stays at its upper bound: conservative.  Scaling
    # it by the equations' own variance factor (27 degrees of freedom) was measured to be overconfident in 4
    # of 50 runs (beyond 4.5 sigma), the bound is not.
    if factor > factor_limit(dof):
        inflate = factor
        warnings.append(f"the equations' residuals are {np.sqrt(factor):.3g} times the sensor noise ({dof} degrees "
                        f"of freedom): errors outside the model; sigma inflated by {np.sqrt(factor):.3g}")
    result = P.ParameterSet(params, covariance=_covariance_of_values(params, cov * inflate))
    return CalibrationResult("ils", result, initial, history, iteration, converged, float(np.sqrt(factor)),
                             time.perf_counter() - t_start, SIGMA_MEANING,
                             {"corrections_natural": corrections, "equations": len(b),
                              "labels": [eq.label for eq in equations], "warnings": warnings,
                              "variance_factor": inflate, "noise_model": noise_plan.model,
                              "noise_raw": noise_plan.raw, "noise_sources": dict(noise_plan.source),
                              "base_motion": noise_plan.motions})


def _covariance_of_values(params: np.ndarray, error_cov: np.ndarray) -> np.ndarray:
    """Covariance of the parameter values from that of the error terms (scale: S = S_hat/(1+t))."""
    jac = np.ones(P.N_PARAMS)
    jac[P.SCALE_MASK] = -params[P.SCALE_MASK]
    return error_cov * np.outer(jac, jac)
