"""The sensor-error columns against the compensation they linearise, and the alignment map against eq. 15's
closed form: one error model for the budget, the modulation study and the design."""

import numpy as np
import pytest

from casadi_sins.core.earth import Site
from casadi_sins.core.rotations import rotation_matrix
from casadi_sins.data.problem import load_problem
from casadi_sins.model import registry as R
from casadi_sins.model.groups.physics import quadrature_nodes, sensed_outputs
from casadi_sins.model.output import compensate_table, output_model
from casadi_sins.nav.errorinputs import body_motion, error_columns
from casadi_sins.nav.errorstate import ErrorModel
from casadi_sins.sim.motion import MotionPiece, kinematics_function

SITE = Site(np.radians(37.5))
ATTITUDE = rotation_matrix(np.array([0.3, -0.5, 0.8]), 0.7)


def _truth():
    """A unit with every extra group but the time offset: the paper's pulse weights, every other term a few
    natural units (the error model is first order: it leaves out products of the errors with the nominal
    biases and misalignments, 1e-3 relative on the paper's unit)."""
    names = tuple(n for n in R.model_names(R.EXTRA_GROUPS) if R.group_of(n).key != "timing")
    values = np.random.default_rng(4).normal(0.0, 3.0, len(names)) * R.natural_scale_of(names)
    values[:R.N_PARAMS][R.SCALE_MASK] = load_problem(None).truth.core[R.SCALE_MASK]
    return names, values


def _estimate(names, truth, x):
    """The estimate whose error state (true minus estimated; scale factors ``S_hat/S - 1``) is ``x``."""
    est = truth - x
    mask = R.relative_mask(names)
    est[mask] = truth[mask] * (1.0 + x[mask])
    return est


@pytest.mark.parametrize("turning", [False, True])
def test_columns_are_the_error_of_the_compensated_increments(turning):
    """A unit still or turning at 10 deg/s: pulses from its true parameters and its extra groups' exact
    physics, compensated once with the truth and once with an estimate off by 1 natural unit of every
    parameter; the difference of the increments is ``G x dt`` to first order (each group's own term).  (The
    time offset has its own test: the compensation keeps the Earth rate in its regressor.)"""
    names, truth = _truth()
    axis = np.array([0.0, 0.6, 0.8]) if turning else None
    dt, n = 0.01, 200
    piece = MotionPiece(0.0, n * dt, ATTITUDE, axis, np.radians(10.0) * n * dt if turning else 0.0, "constant")
    kinematics = kinematics_function([piece], SITE.earth_rate, SITE.g)
    t0 = np.arange(n) * dt
    at = quadrature_nodes(kinematics, t0, t0 + dt)
    dv_f, gyro_extra, accel_extra = sensed_outputs(kinematics, t0, t0 + dt, dict(zip(names, truth)),
                                                   [R.GROUPS[k] for k in R.groups_in(names)])
    gyro, accel = output_model(at.integral(at.rate), dv_f, truth, dt)
    gyro, accel = gyro + gyro_extra / truth[R.GYRO_SCALE], accel + accel_extra / truth[R.ACCEL_SCALE]
    x = R.natural_scale_of(names) * np.random.default_rng(5).choice([-1.0, 1.0], len(names))
    exact = compensate_table(gyro, accel, truth, names, dt)
    wrong = compensate_table(gyro, accel, _estimate(names, truth, x), names, dt)
    mid = slice(2, n - 2)  # the regressors' boundary rates
    times = t0[mid] + dt / 2
    rate, force, rest = body_motion(piece.attitude_at(times), SITE.earth_rate, SITE.g, piece.turn_rate(times))
    g_w, g_f = error_columns(names, rate, force, rest)
    for actual, columns in ((wrong[0] - exact[0], g_w), (wrong[1] - exact[1], g_f)):
        predicted = columns @ x * dt
        assert np.abs(actual[mid] - predicted).max() < 1e-3 * np.abs(predicted).max()


def test_the_time_offsets_column_is_the_shift_of_the_truth():
    """A time offset ``tau`` makes the accelerometers sense ``f(t + tau)``: per unit ``tau`` the increments
    change by the turn's ``-(w_table x f) dt`` (the Earth rate does not turn ``f`` in the body), the column."""
    piece = MotionPiece(0.0, 2.0, ATTITUDE, np.array([0.6, 0.0, 0.8]), np.radians(30.0), "constant")
    kinematics = kinematics_function([piece], SITE.earth_rate, SITE.g)
    t0, dt, tau = np.arange(0.5, 1.5, 0.01), 0.01, 1e-4
    shifted = sensed_outputs(kinematics, t0, t0 + dt, {"accel_time_offset": tau}, [R.GROUPS["timing"]])[0]
    still = sensed_outputs(kinematics, t0, t0 + dt, {}, [R.GROUPS["timing"]])[0]
    times = t0 + dt / 2
    rate, force, rest = body_motion(piece.attitude_at(times), SITE.earth_rate, SITE.g, piece.turn_rate(times))
    column = error_columns(R.model_names(("timing",)), rate, force, rest)[1][:, :, -1]
    np.testing.assert_allclose((shifted - still) / tau, column * dt, rtol=1e-3, atol=1e-3 * np.abs(column * dt).max())


def test_each_extra_column_is_its_own_group_only():
    """An extra group's columns are zero on the other sensor: g-sensitivity and asymmetry on the gyros,
    quadratic, cross-quadratic, lever arms and time offset on the accelerometers."""
    names = R.model_names(R.EXTRA_GROUPS)
    g_w, g_f = error_columns(names, np.array([0.1, -0.2, 0.3]), np.array([1.0, 2.0, 9.5]), np.zeros(3))
    for k, name in enumerate(names[R.N_PARAMS:], start=R.N_PARAMS):
        other = g_f if R.group_of(name).sensor == "gyro" else g_w
        assert not other[:, k].any(), name


def test_the_alignment_map_is_eq_15_in_closed_form():
    """The linearised coarse alignment (Kang et al. 2013, eqs. 14-15) levels on the measured specific force
    and finds north on the measured Earth rate: ``phi_E = -df_N/g``, ``phi_N = df_E/g``,
    ``phi_U = tan(L) df_E/g - dw_E/w_ie,N`` with ``df = C G_f``, ``dw = C G_w`` at rest, for every group."""
    model = ErrorModel(SITE, R.model_names(R.EXTRA_GROUPS))
    dw, df = model.inputs(ATTITUDE)
    g, w_n = SITE.g, SITE.earth_rate[1]
    closed = np.stack([-df[1] / g, df[0] / g, np.tan(SITE.latitude) * df[0] / g - dw[0] / w_n])
    np.testing.assert_allclose(model.alignment_map(ATTITUDE), closed, rtol=1e-9, atol=1e-12 * np.abs(closed).max())
