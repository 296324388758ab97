import numpy as np
import pytest

from casadi_sins import parameters as P


def random_parameters(rng):
    p = np.zeros(P.N_PARAMS)
    p[P.ACCEL_BIAS] = rng.normal(0, 0.01, 3)
    p[P.ACCEL_SCALE] = 3.5e-4 * (1 + rng.normal(0, 0.01, 3))
    p[P.ACCEL_MISALIGN] = rng.normal(0, 2e-3, 3)
    p[P.GYRO_BIAS] = rng.normal(0, 1e-6, 3)
    p[P.GYRO_SCALE] = 1e-7 * (1 + rng.normal(0, 0.01, 3))
    p[P.GYRO_MISALIGN] = rng.normal(0, 2e-3, 6)
    return p


@pytest.mark.parametrize("seed", range(5))
def test_compensation_inverts_the_output_model_to_round_off(seed):
    rng = np.random.default_rng(seed)
    p, dt = random_parameters(rng), 0.01
    dtheta = rng.normal(0, 2e-3, (200, 3))
    dv = rng.normal(0, 0.1, (200, 3))
    dn_g, dn_a = P.output_model(dtheta, dv, p, dt)
    back_theta, back_v = P.compensate(dn_g, dn_a, p, dt)
    np.testing.assert_allclose(back_theta, dtheta, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back_v, dv, rtol=0, atol=1e-13)
    # and the other way round
    again_g, again_a = P.output_model(back_theta, back_v, p, dt)
    np.testing.assert_allclose(again_g, dn_g, rtol=1e-12)


def test_output_model_matches_eq1_written_out():
    rng = np.random.default_rng(9)
    p, dt = random_parameters(rng), 0.01
    dtheta, dv = rng.normal(size=3) * 1e-3, rng.normal(size=3) * 0.1
    k_g = np.eye(3)
    for n, (i, j) in enumerate(P.GYRO_MISALIGN_ENTRIES):
        k_g[i, j] = p[P.GYRO_MISALIGN][n]
    k_a = np.eye(3)
    for n, (i, j) in enumerate(P.ACCEL_MISALIGN_ENTRIES):
        k_a[i, j] = p[P.ACCEL_MISALIGN][n]
    assert np.allclose(k_a, np.tril(k_a))
    dn_g, dn_a = P.output_model(dtheta[None], dv[None], p, dt)
    np.testing.assert_allclose(dn_g[0], (k_g @ dtheta + p[P.GYRO_BIAS] * dt) / p[P.GYRO_SCALE], rtol=1e-13)
    np.testing.assert_allclose(dn_a[0], (k_a @ dv + p[P.ACCEL_BIAS] * dt) / p[P.ACCEL_SCALE], rtol=1e-13)


def test_compensation_uses_the_exact_inverse_not_first_order():
    rng = np.random.default_rng(2)
    p, dt = random_parameters(rng), 0.01
    dv = np.array([[3.0, -4.0, 9.8]]) * dt
    _, dn_a = P.output_model(np.zeros((1, 3)), dv, p, dt)
    _, back = P.compensate(np.zeros((1, 3)), dn_a, p, dt)
    k_a, *_ = (np.asarray(m) for m in P.sensor_matrices(p))
    first_order = (2 * np.eye(3) - k_a) @ (p[P.ACCEL_SCALE] * dn_a[0] - p[P.ACCEL_BIAS] * dt)
    assert np.abs(back[0] - dv[0]).max() < 1e-15
    assert np.abs(first_order - dv[0]).max() > 1e-9  # I - k would be wrong by misalignment products


def test_error_update_eqs_22_25_recover_the_truth():
    rng = np.random.default_rng(3)
    truth = random_parameters(rng)
    estimate = truth + random_parameters(rng) * 1e-3
    estimate[P.SCALE_MASK] = truth[P.SCALE_MASK] * (1 + rng.normal(0, 1e-4, 6))
    # the paper's error state: t_ii = S_hat/S - 1, t_ij = k - k_hat, eps = B - B_hat
    errors = truth - estimate
    errors[P.SCALE_MASK] = estimate[P.SCALE_MASK] / truth[P.SCALE_MASK] - 1
    np.testing.assert_allclose(P.apply_error_estimate(estimate, errors), truth, rtol=1e-14, atol=1e-18)


def test_natural_errors_units():
    truth = random_parameters(np.random.default_rng(4))
    est = truth.copy()
    est[P.INDEX["accel_bias_x"]] += 1e-6 * 9.80665  # 1 ug
    est[P.INDEX["gyro_scale_y"]] *= 1 + 2e-6  # 2 ppm
    est[P.INDEX["gyro_misalign_zy"]] += np.radians(3 / 3600)  # 3 arcsec
    est[P.INDEX["gyro_bias_z"]] += np.radians(0.01) / 3600  # 0.01 deg/h
    err = P.natural_errors(est, truth)
    assert err[P.INDEX["accel_bias_x"]] == pytest.approx(1.0)
    assert err[P.INDEX["gyro_scale_y"]] == pytest.approx(2.0)
    assert err[P.INDEX["gyro_misalign_zy"]] == pytest.approx(3.0)
    assert err[P.INDEX["gyro_bias_z"]] == pytest.approx(0.01)
    assert np.count_nonzero(np.abs(err) > 1e-9) == 4


def test_table_round_trip(tmp_path):
    rng = np.random.default_rng(5)
    params = P.ParameterSet(random_parameters(rng), sigma=np.abs(random_parameters(rng)) * 1e-3)
    path = P.write_table(tmp_path / "p.csv", params)
    header = path.read_text().splitlines()[0]
    assert header.startswith("parameter,unit,value,sigma")
    back = P.read_table(path)
    np.testing.assert_allclose(back.values, params.values, rtol=1e-11)
    np.testing.assert_allclose(back.sigma, params.sigma, rtol=1e-11)
    truth = P.write_table(tmp_path / "t.csv", params, as_truth=True)
    assert truth.read_text().splitlines()[0] == "parameter,unit,value"
    assert P.read_table(truth).sigma is None


def test_table_accepts_natural_units(tmp_path):
    path = tmp_path / "t.csv"
    rows = [f"{n},{u},{0.0 if 'scale' not in n else 1e-4}" for n, u in zip(P.NAMES, P.UNITS)]
    rows[P.INDEX["gyro_scale_x"]] = "gyro_scale_x,deg/pulse,5.644819e-6"
    path.write_text("parameter,unit,value\n" + "\n".join(rows) + "\n")
    assert P.read_table(path)["gyro_scale_x"] == pytest.approx(np.radians(5.644819e-6), rel=1e-15)


@pytest.mark.parametrize("mutate,message", [
    (lambda rows: rows[:-1], "missing parameters gyro_misalign_zy"),
    (lambda rows: rows + ["accel_bias_q,m/s^2,0"], "line 23: unknown parameter 'accel_bias_q'"),
    (lambda rows: rows + [rows[0]], "line 23: parameter 'accel_bias_x' given twice"),
    (lambda rows: ["accel_bias_x,m/s^2,nan"] + rows[1:], "line 2: value of accel_bias_x is not finite"),
    (lambda rows: ["accel_bias_x,deg/h,0"] + rows[1:], "line 2: unit 'deg/h' does not fit accel_bias_x"),
    (lambda rows: ["accel_bias_x,furlong,0"] + rows[1:], "line 2: unknown unit 'furlong'"),
])
def test_bad_tables_name_file_and_line(tmp_path, mutate, message):
    rows = [f"{n},{u},1e-4" for n, u in zip(P.NAMES, P.UNITS)]
    path = tmp_path / "bad.csv"
    path.write_text("parameter,unit,value\n" + "\n".join(mutate(rows)) + "\n")
    with pytest.raises(P.ParameterTableError) as info:
        P.read_table(path)
    assert str(path) in str(info.value) and message in str(info.value)
