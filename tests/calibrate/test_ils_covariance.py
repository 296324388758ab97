"""The ILS's equation covariance, computed exactly in one backward pass (:mod:`calibrate.ils.covariance`),
against a Monte Carlo of the same linear model: the random draws the package used before (the oracle), with
a counter's remainders at the ends of the alignment segment drawn as issue 16's prototype drew them."""

import dataclasses

import numpy as np
import pytest

from casadi_sins.calibrate.ils.covariance import equation_covariance, equation_covariances
from casadi_sins.calibrate.ils.equations import Equation, build_equations, coefficient_operator, equation_segments
from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.calibrate.steps import ROTATION_STEP_S, GroupSteps, group_track, plan_steps
from casadi_sins.core.threads import single_threaded
from casadi_sins.data.recording import Recording
from casadi_sins.model.noise import SensorNoise
from casadi_sins.model.output import compensate
from casadi_sins.nav.alignment import alignment_error
from casadi_sins.nav.navigation import GroupNavigation
from casadi_sins.noise.kalman import ACC, DV, PHI, Layout, NoiseSystem, gauss_markov_integrals
from casadi_sins.noise.plan import plan_noise

DRAWS = 2500


@dataclasses.dataclass
class _GroupDraws:
    """Random draws of one group's noise along its steps."""

    velocity: np.ndarray  # (M, 3, S) velocity error after each static step
    v_align: np.ndarray  # (M, 3, 3) the velocity's response to an initial attitude error
    accel_mean: np.ndarray  # (3, S) noise of the alignment segment's mean specific force
    gyro_mean: np.ndarray  # (3, S) noise of its mean rate
    final_state: np.ndarray  # (n, S)


def monte_carlo_covariance(rec: Recording, params: np.ndarray, navs: list[GroupNavigation], equations: list[Equation],
                        noise: SensorNoise, north_quadratic: bool = True, samples: int = 3000,
                        seed: int = 0) -> np.ndarray:
    """Covariance (m, m) of the equations' right-hand sides under the sensor noise model (module docstring)."""
    rng = np.random.default_rng(seed)
    model = noise.complete()
    layout = Layout.of(model)
    by_group: dict[int, list[int]] = {}
    for i, eq in enumerate(equations):
        by_group.setdefault(eq.group, []).append(i)
    draws = np.zeros((len(equations), samples))
    carried = None  # (state draws, end time) of the previous group
    for nav in navs:
        plan = plan_steps(rec, nav.group, 1.0, ROTATION_STEP_S)
        stops = np.cumsum(np.round(plan.step_dt / rec.dt).astype(int)) - 1
        track = group_track(plan, [], nav.initial_attitude, nav.quaternion[stops].T, True)
        system = NoiseSystem([track], rec.site.g, rec.site.earth_rate)
        x = _initial_draws(layout, model, carried, float(plan.start_time), samples, rng)
        first_seg = rec.group_segments(nav.group)[0].number
        group = _draw_group(system, track, plan, layout, model, x, first_seg, samples, rng)
        first = rec.segment_samples(rec.group_segments(nav.group)[0])
        dth, dvel = compensate(rec.gyro[first], rec.accel[first], params, rec.dt)
        phi0 = alignment_error(dvel.mean(axis=0) / rec.dt, dth.mean(axis=0) / rec.dt,
                               np.vstack([group.accel_mean, group.gyro_mean]))
        total = group.velocity + np.einsum("kij,js->kis", group.v_align, phi0)
        carried = (group.final_state.copy(), float(plan.start_time + plan.step_dt.sum()))
        rows = by_group.get(nav.group, [])
        with_alignment = any(equations[i].segment == first_seg for i in rows)
        for seg, axes in equation_segments(rec, nav.group, with_alignment):
            _segment_coefficients(draws, plan, total, seg, axes, rows, equations, nav.group, north_quadratic, samples)
    return np.cov(draws)


def _initial_draws(layout: Layout, model: SensorNoise, carried, start: float, samples: int,
                   rng: np.random.Generator) -> np.ndarray:
    """The state at a group's start: zero, but for the biases, which wander on from the previous group (one
    Gauss-Markov process over the recording)."""
    x = np.zeros((layout.n, samples))
    if layout.markov:
        for sl, sigma, tau in ((layout.bg, model.gyro_bias_instability, model.gyro_bias_tau),
                               (layout.ba, model.accel_bias_instability, model.accel_bias_tau)):
            beta = gauss_markov_integrals(max(start - carried[1], 0.0), tau)[0] if carried else 0.0
            previous = carried[0][sl] if carried else 0.0
            x[sl] = beta * previous + rng.standard_normal((3, samples)) * sigma * np.sqrt(1.0 - beta**2)
    return x


def _draw_group(system: NoiseSystem, track, plan: GroupSteps, layout: Layout, model: SensorNoise, x: np.ndarray,
                first_seg: int, samples: int, rng: np.random.Generator) -> _GroupDraws:
    """Propagate the draws through a group's steps; rotations are composed into one transition."""
    n = layout.n
    phi, q = system.transitions(track, model, layout)
    response = np.zeros((n, 3))  # the state's response to an initial attitude error
    response[PHI] = np.eye(3)
    velocity = np.zeros((len(plan.step_dt), 3, samples))
    v_align = np.zeros((len(plan.step_dt), 3, 3))
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
    # the alignment (eq. 14) sees the first segment's mean noise: f_noise = C^T (dv - int f x phi) / T, and the
    # pulse remainders at the segment's two ends, (e_end - e_start) / T
    duration = float(plan.step_dt[plan.step_segment == first_seg].sum())
    c1 = track.attitude[last_first]
    accel_mean = c1.T @ (velocity[last_first] - f_cross_phi) / duration
    gyro_mean = gyro_sum / duration
    for mean, q in ((accel_mean, model.accel_quantization), (gyro_mean, model.gyro_quantization)):
        mean += (rng.standard_normal((3, samples)) - rng.standard_normal((3, samples))) * q[:, None] / duration
    return _GroupDraws(velocity, v_align, accel_mean, gyro_mean, x)


def _segment_coefficients(draws, plan: GroupSteps, total, seg, axes, rows, equations, group: int,
                          north_quadratic: bool, samples: int) -> None:
    """The fitted coefficients of one segment's velocity draws, into their equations' rows of ``draws``."""
    steps = np.flatnonzero(plan.step_segment == seg.number)
    tau = np.cumsum(plan.step_dt[steps])
    before = total[steps[0] - 1] if steps[0] > 0 else np.zeros((3, samples))
    for axis in axes:
        ops, _ = coefficient_operator(tau, 1 if axis == 2 else 2)
        if axis == 1 and not north_quadratic:
            ops = ops[:1]
        coefficients = ops @ (total[steps, axis] - before[axis])
        for order in range(len(ops)):
            i = next(i for i in rows if equations[i] == Equation(group, seg.number, axis, order + 1))
            draws[i] = coefficients[order]


def _psd_sqrt(q: np.ndarray) -> np.ndarray:
    """A square root ``L L^T = Q`` of a positive semi-definite matrix (eigen-decomposition: Q may be singular)."""
    w, v = np.linalg.eigh(0.5 * (q + q.T))
    return v * np.sqrt(np.clip(w, 0.0, None))


@pytest.fixture(scope="module")
def equations(kang_sim):
    rec = kang_sim.recording
    params = rough_parameters(rec).core
    _, _, eqs, navs = build_equations(rec, params)
    return rec, params, eqs, navs, plan_noise(rec, params).model


#: Remainders (m/s, rad) ten times those of issue 16's coarse counter (pulse / sqrt(12) = 1e-4 m/s, 2.8e-8 rad),
#: so that the equations' variances show them well beyond the draws' sampling error (the coarse size adds 3 %).
QUANTIZATION = dict(accel_quantization=np.full(3, 1.0e-3), gyro_quantization=np.full(3, 2.8e-7))


@pytest.mark.parametrize("terms", ["white", "bias instability", "quantization"])
def test_exact_covariance_equals_a_monte_carlo_of_the_same_model(equations, terms):
    """Standard deviations and correlations of the 48 equations agree with 2,500 draws within the draws'
    sampling error: a variance's relative standard error is sqrt(2 / N), a correlation's below 1 / sqrt(N);
    the bounds are 4.5 of those (48 equations, 1,128 correlations).  With a counter's quantization the
    remainders at the ends of the alignment segment are drawn (issue 16)."""
    rec, params, eqs, navs, model = equations
    if terms == "bias instability":
        model = dataclasses.replace(model, gyro_bias_instability=1e-9, gyro_bias_tau=300.0,
                                    accel_bias_instability=5e-6, accel_bias_tau=200.0)
    if terms == "quantization":
        model = dataclasses.replace(model, **QUANTIZATION)
    exact = equation_covariance(rec, params, navs, eqs, model)
    with single_threaded():  # small matrices times thousands of draws: BLAS threads only slow them down
        drawn = monte_carlo_covariance(rec, params, navs, eqs, model, samples=DRAWS, seed=3)
    sd_exact, sd_drawn = np.sqrt(np.diag(exact)), np.sqrt(np.diag(drawn))
    variance_ratio = (sd_drawn / sd_exact) ** 2
    assert np.max(np.abs(variance_ratio - 1.0)) < 4.5 * np.sqrt(2.0 / DRAWS)
    corr_exact = exact / np.outer(sd_exact, sd_exact)
    corr_drawn = drawn / np.outer(sd_drawn, sd_drawn)
    assert np.max(np.abs(corr_exact - corr_drawn)) < 4.5 / np.sqrt(DRAWS)
    # and the comparison can fail: a covariance with one term missing is far outside these bounds
    smaller = (dict(accel_quantization=np.zeros(3), gyro_quantization=np.zeros(3)) if terms == "quantization"
               else dict(accel_vrw=model.accel_vrw * 0.9))
    without = equation_covariance(rec, params, navs, eqs, dataclasses.replace(model, **smaller))
    assert np.max(np.abs(np.diag(drawn) / np.diag(without) - 1.0)) > 4.5 * np.sqrt(2.0 / DRAWS)


def test_several_noise_models_share_one_pass_and_independent_sources_add(equations):
    """One propagation for several noise models with the same transitions (the ILS's unit instabilities):
    each equals its own pass, and the covariances of independent sources add up to that of both together."""
    rec, params, eqs, navs, model = equations
    quiet = dict(gyro_arw=np.zeros(3), accel_vrw=np.zeros(3), gyro_quantization=np.zeros(3),
                 accel_quantization=np.zeros(3), gyro_bias_tau=400.0, accel_bias_tau=400.0)
    gyro = dataclasses.replace(model, **quiet, gyro_bias_instability=1e-9, accel_bias_instability=0.0)
    accel = dataclasses.replace(model, **quiet, gyro_bias_instability=0.0, accel_bias_instability=5e-6)
    both = dataclasses.replace(model, **quiet, gyro_bias_instability=1e-9, accel_bias_instability=5e-6)
    joint = equation_covariances(rec, params, navs, eqs, [gyro, accel])
    alone = [equation_covariance(rec, params, navs, eqs, m) for m in (gyro, accel)]
    scale = np.abs(joint).max()
    assert np.abs(joint - np.stack(alone)).max() <= 1e-12 * scale
    assert np.abs(joint.sum(axis=0) - equation_covariance(rec, params, navs, eqs, both)).max() <= 1e-10 * scale
    assert np.abs(alone[0]).max() > 0 and np.abs(alone[1]).max() > 0
    with pytest.raises(ValueError, match="different transitions"):
        equation_covariances(rec, params, navs, eqs, [gyro, dataclasses.replace(accel, accel_bias_tau=100.0)])
