"""Error budget: the linear model against the navigation it predicts, and the split by source."""

import numpy as np
import pytest

from casadi_sins.core import orientation
from casadi_sins.core.units import UG
from casadi_sins.model import registry as R
from casadi_sins.nav.free_inertial import navigate_free
from casadi_sins.sim import simulate
from casadi_sins.studies import budget as B
from casadi_sins.studies.navcheck import navigation_problem
from casadi_sins.studies.prediction import predict_problem


@pytest.fixture(scope="module")
def quiet_navigation(kang_problem):
    quiet = kang_problem.with_changes(accel_noise_ug=0.0, gyro_noise_deg_h=0.0, start_attitude_deg=0.0)
    return simulate(navigation_problem(quiet), seed=0)


@pytest.mark.parametrize("name,size", [("gyro_bias_y", np.radians(0.01) / 3600),
                                       ("gyro_bias_z", np.radians(0.01) / 3600), ("gyro_scale_z", 10e-6),
                                       ("accel_bias_y", 10 * UG)])
def test_linear_model_predicts_the_navigation_of_a_parameter_error(quiet_navigation, name, size):
    """Deterministic check of every sign: one parameter error through the budget's linear model and
    through the nonlinear free-inertial navigation (north gyro 0.01 deg/h: ~1.3 km east after 1 h)."""
    rec, truth = quiet_navigation.recording, quiet_navigation.truth.values
    k = R.NAMES.index(name)
    errors = np.zeros(R.N_PARAMS)
    errors[k] = size
    estimate = truth.copy()
    if R.SCALE_MASK[k]:
        estimate[k] *= 1 + size
    else:
        estimate[k] -= size  # the paper's convention: error = true - estimated
    run = navigate_free(rec, estimate, 300.0, name)
    t, predicted = B.propagate_mean(errors, orientation.orientation_to_dcm("ENU"), rec.site.latitude, 0.0, rec.site.g,
                                    rec.rate_hz, 3600.0)
    actual = np.column_stack([run.north_m, run.east_m])[[int(round(x)) - 1 for x in t[1:]]]
    assert np.abs(actual - predicted[1:]).max() < 0.02 * np.abs(actual).max() + 0.05


def test_alignment_cancels_the_east_accelerometer_bias(quiet_navigation):
    """Level unit, x east: the alignment's tilt cancels an east bias exactly (a north bias also tilts the
    computed heading by tan(L) f_N / g and drifts; checked against the navigation above)."""
    rec = quiet_navigation.recording
    errors = np.zeros(R.N_PARAMS)
    errors[R.NAMES.index("accel_bias_x")] = 10 * UG
    _, predicted = B.propagate_mean(errors, orientation.orientation_to_dcm("ENU"), rec.site.latitude, 0.0,
                                    rec.site.g, rec.rate_hz, 3600.0)
    assert np.abs(predicted).max() < 0.01  # m: the tilt from the alignment cancels the bias exactly


def test_budget_splits_into_sources_that_add_up(kang_problem):

    pred = predict_problem(kang_problem)
    budget = B.error_budget(np.diag(np.diag(pred.nominal.covariance)), pred.nominal.values,
                            orientation.orientation_to_dcm("ENU"), kang_problem.site.latitude, 0.0, kang_problem.site.g,
                            50.0, 0.01, 100.0, duration_s=86400.0)
    # with a diagonal parameter covariance the sources are independent: variances add to the total
    summed = np.sqrt(sum(c**2 for c in budget.contributions.values()))
    np.testing.assert_allclose(summed[1:], budget.total[1:], rtol=1e-6)
    table = budget.table([3600.0, 86400.0])
    assert set(table["source"]) >= {"residual gyro bias", "alignment noise", "sensor noise in navigation", "total"}


@pytest.mark.parametrize("sensor,axis", [("gyro", "z"), ("gyro", "x"), ("accel", "z")])
def test_an_extra_groups_error_at_rest_acts_as_the_bias_its_physics_gives(kang_problem, sensor, axis):
    """At rest in ENU (body z up) a g-sensitivity error on the up force axis is a gyro
    bias error of g times it; a quadratic-scale error of the up accelerometer an accelerometer bias of g^2
    times it: the budget's extra sources come from the groups' own corrections."""
    g = kang_problem.site.g
    if sensor == "gyro":
        names, extra, factor = R.model_names(("gyro_gsens",)), f"gyro_gsens_{axis}z", g
    else:
        names, extra, factor = R.model_names(("quadratic",)), f"accel_quadratic_{axis}", g**2
    nominal = np.concatenate([kang_problem.truth.core, np.zeros(len(names) - R.N_PARAMS)])
    sigma = 1e-9
    extra_cov = np.zeros((len(names), len(names)))
    extra_cov[names.index(extra), names.index(extra)] = sigma**2
    bias_cov = np.zeros_like(extra_cov)
    k = names.index(f"{sensor}_bias_{axis}")
    bias_cov[k, k] = (sigma * factor) ** 2
    run = [B.problem_budget(kang_problem, nominal, cov, "ENU", 2.0, names).total for cov in (extra_cov, bias_cov)]
    np.testing.assert_allclose(run[0], run[1], rtol=1e-6, atol=1e-9)
    assert run[0][-1].max() > 1e-3


@pytest.mark.parametrize("hours, message", [("1e7", "at most 1000"), ("nan", "--hours: 'nan' is not a finite"),
                                           ("0", "at most 1000"), ("1001", "at most 1000")])
def test_budget_hours_beyond_the_limit_are_one_line(tmp_path, capsys, hours, message):
    from casadi_sins.cli import main

    out = tmp_path / "b"
    assert main(["budget", "problems/kang2013.toml", "--hours", hours, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err
    assert not out.exists()


def test_the_plot_draws_no_zero_contribution_at_a_floor(kang_problem):
    """A source that contributes nothing (here the gyro biases, at zero sigma) is left out of the log plot and
    named as zero; no curve holds the old 1e-3 m floor; the first instant (0 m) is a gap, not a floor."""
    pred = predict_problem(kang_problem)
    cov = np.diag(np.diag(pred.nominal.covariance)).copy()
    cov[R.GYRO_BIAS, R.GYRO_BIAS] = 0.0
    budget = B.error_budget(cov, pred.nominal.values, orientation.orientation_to_dcm("ENU"), kang_problem.site.latitude,
                            0.0, kang_problem.site.g, 50.0, 0.01, 100.0, duration_s=3600.0)
    for axis in (0, 1):
        curves, zero = B.drawn_curves(budget, axis)
        assert "residual gyro bias" in zero and "residual gyro bias" not in curves and "total" in curves
        for values in curves.values():
            finite = values[np.isfinite(values)]
            assert finite.size and np.all(finite > 0) and not np.any(finite == 1e-3)


def test_budget_params_takes_the_correlations_of_the_tables_report(tmp_path, short_problem, capsys):
    """budget --params with a table from calibrate uses the covariance its report holds (the error budget
    differs from the sigma-only one), and says so; without the report it says the correlations are unknown."""
    import shutil

    from casadi_sins.cli import main
    from casadi_sins.sim import write_simulation

    rec = write_simulation(simulate(short_problem, seed=12), tmp_path / "rec")
    assert main(["calibrate", str(rec), "--out", str(tmp_path / "P.csv"), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["budget", str(rec), "--params", str(tmp_path / "P.csv"), "--out", str(tmp_path / "b1"),
                 "--no-progress"]) == 0
    assert "with the correlations of its report" in capsys.readouterr().out
    shutil.copy(tmp_path / "P.csv", tmp_path / "bare.csv")
    assert main(["budget", str(rec), "--params", str(tmp_path / "bare.csv"), "--out", str(tmp_path / "b2"),
                 "--no-progress"]) == 0
    assert "correlations between parameters not known" in capsys.readouterr().out
    import pandas as pd
    stem = rec.stem
    with_corr = pd.read_csv(tmp_path / "b1" / f"{stem}-budget.csv").set_index("source")
    sigma_only = pd.read_csv(tmp_path / "b2" / f"{stem}-budget.csv").set_index("source")
    assert not np.allclose(with_corr.loc["total"].to_numpy(float), sigma_only.loc["total"].to_numpy(float), rtol=1e-3)
