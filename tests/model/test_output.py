import numpy as np
import pytest

from casadi_sins.model import registry as R
from casadi_sins.model.output import apply_error_estimate, compensate, output_model, sensor_matrices
from casadi_sins.model.parameters import natural_errors


def random_parameters(rng):
    p = np.zeros(R.N_PARAMS)
    p[R.ACCEL_BIAS] = rng.normal(0, 0.01, 3)
    p[R.ACCEL_SCALE] = 3.5e-4 * (1 + rng.normal(0, 0.01, 3))
    p[R.ACCEL_MISALIGN] = rng.normal(0, 2e-3, 3)
    p[R.GYRO_BIAS] = rng.normal(0, 1e-6, 3)
    p[R.GYRO_SCALE] = 1e-7 * (1 + rng.normal(0, 0.01, 3))
    p[R.GYRO_MISALIGN] = rng.normal(0, 2e-3, 6)
    return p


@pytest.mark.parametrize("seed", range(5))
def test_compensation_inverts_the_output_model_to_round_off(seed):
    rng = np.random.default_rng(seed)
    p, dt = random_parameters(rng), 0.01
    dtheta = rng.normal(0, 2e-3, (200, 3))
    dv = rng.normal(0, 0.1, (200, 3))
    dn_g, dn_a = output_model(dtheta, dv, p, dt)
    back_theta, back_v = compensate(dn_g, dn_a, p, dt)
    np.testing.assert_allclose(back_theta, dtheta, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back_v, dv, rtol=0, atol=1e-13)
    # and the other way round
    again_g, again_a = output_model(back_theta, back_v, p, dt)
    np.testing.assert_allclose(again_g, dn_g, rtol=1e-12)


def test_output_model_matches_eq1_written_out():
    rng = np.random.default_rng(9)
    p, dt = random_parameters(rng), 0.01
    dtheta, dv = rng.normal(size=3) * 1e-3, rng.normal(size=3) * 0.1
    k_g = np.eye(3)
    for n, (i, j) in enumerate(R.GYRO_MISALIGN_ENTRIES):
        k_g[i, j] = p[R.GYRO_MISALIGN][n]
    k_a = np.eye(3)
    for n, (i, j) in enumerate(R.ACCEL_MISALIGN_ENTRIES):
        k_a[i, j] = p[R.ACCEL_MISALIGN][n]
    assert np.allclose(k_a, np.tril(k_a))
    dn_g, dn_a = output_model(dtheta[None], dv[None], p, dt)
    np.testing.assert_allclose(dn_g[0], (k_g @ dtheta + p[R.GYRO_BIAS] * dt) / p[R.GYRO_SCALE], rtol=1e-13)
    np.testing.assert_allclose(dn_a[0], (k_a @ dv + p[R.ACCEL_BIAS] * dt) / p[R.ACCEL_SCALE], rtol=1e-13)


def test_compensation_uses_the_exact_inverse_not_first_order():
    rng = np.random.default_rng(2)
    p, dt = random_parameters(rng), 0.01
    dv = np.array([[3.0, -4.0, 9.8]]) * dt
    _, dn_a = output_model(np.zeros((1, 3)), dv, p, dt)
    _, back = compensate(np.zeros((1, 3)), dn_a, p, dt)
    k_a, *_ = (np.asarray(m) for m in sensor_matrices(p))
    first_order = (2 * np.eye(3) - k_a) @ (p[R.ACCEL_SCALE] * dn_a[0] - p[R.ACCEL_BIAS] * dt)
    assert np.abs(back[0] - dv[0]).max() < 1e-15
    assert np.abs(first_order - dv[0]).max() > 1e-9  # I - k would be wrong by misalignment products


def test_error_update_eqs_22_25_recover_the_truth():
    rng = np.random.default_rng(3)
    truth = random_parameters(rng)
    estimate = truth + random_parameters(rng) * 1e-3
    estimate[R.SCALE_MASK] = truth[R.SCALE_MASK] * (1 + rng.normal(0, 1e-4, 6))
    # the paper's error state: t_ii = S_hat/S - 1, t_ij = k - k_hat, eps = B - B_hat
    errors = truth - estimate
    errors[R.SCALE_MASK] = estimate[R.SCALE_MASK] / truth[R.SCALE_MASK] - 1
    np.testing.assert_allclose(apply_error_estimate(estimate, errors), truth, rtol=1e-14, atol=1e-18)


def test_natural_errors_units():
    truth = random_parameters(np.random.default_rng(4))
    est = truth.copy()
    est[R.NAMES.index("accel_bias_x")] += 1e-6 * 9.80665  # 1 ug
    est[R.NAMES.index("gyro_scale_y")] *= 1 + 2e-6  # 2 ppm
    est[R.NAMES.index("gyro_misalign_zy")] += np.radians(3 / 3600)  # 3 arcsec
    est[R.NAMES.index("gyro_bias_z")] += np.radians(0.01) / 3600  # 0.01 deg/h
    err = natural_errors(est, truth)
    assert err[R.NAMES.index("accel_bias_x")] == pytest.approx(1.0)
    assert err[R.NAMES.index("gyro_scale_y")] == pytest.approx(2.0)
    assert err[R.NAMES.index("gyro_misalign_zy")] == pytest.approx(3.0)
    assert err[R.NAMES.index("gyro_bias_z")] == pytest.approx(0.01)
    assert np.count_nonzero(np.abs(err) > 1e-9) == 4
