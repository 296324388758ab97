"""The navigation check after calibration: free-inertial navigation on a static base."""

import numpy as np
import pytest

from casadi_sins.model import registry as R
from casadi_sins.nav.free_inertial import NAUTICAL_MILE, navigate_free
from casadi_sins.sim import simulate
from casadi_sins.studies.navcheck import navigation_check, navigation_problem


def test_noise_free_truth_stays_put_for_an_hour(kang_problem):
    """Simulator and free-inertial step agree: with the true parameters and no noise, < 1 mm after 1 h."""
    quiet = kang_problem.with_changes(accel_noise_ug=0.0, gyro_noise_deg_h=0.0)
    sim = simulate(navigation_problem(quiet), seed=0)
    run = navigate_free(sim.recording, sim.truth.values, 300.0, "truth")
    assert run.time[-1] == pytest.approx(3600.0) and run.horizontal_m.max() < 1e-3


def test_a_gyro_bias_error_drifts_as_the_earth_rate_coupling_predicts(kang_problem):
    """A 0.01 deg/h east-gyro bias error misaligns the heading by eps/(Omega cos L); over 1 h the position
    error grows to roughly R eps t (linear drift of the Schuler-averaged velocity): ~0.1-0.3 nmile."""
    quiet = kang_problem.with_changes(accel_noise_ug=0.0, gyro_noise_deg_h=0.0)
    sim = simulate(navigation_problem(quiet), seed=0)
    biased = sim.truth.values.copy()
    biased[R.GYRO_BIAS] -= np.radians(0.01) / 3600  # every gyro 0.01 deg/h off
    run = navigate_free(sim.recording, biased, 300.0, "biased")
    assert 0.05 * NAUTICAL_MILE < run.horizontal_m[-1] < 1.0 * NAUTICAL_MILE


def test_navigation_check_orders_rough_calibrated_truth(kang_problem, kang_nlp):

    tables = {"nlp": kang_nlp.parameters.values}
    _, table = navigation_check(kang_problem, tables, seed=11)
    errors = dict(zip(table["parameters"], table["horizontal error at end (nmi)"]))
    assert errors["rough initial values"] > 1.0  # the paper's rough values are useless for navigation
    assert errors["nlp"] < 0.1 and errors["truth"] < 0.1
