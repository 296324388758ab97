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
