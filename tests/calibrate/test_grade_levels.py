"""Thresholds by grade (calibrate.limits) and the separability of raw counts' biases (model.parameters)."""

import numpy as np

from casadi_sins.calibrate.limits import GRADE_FACTOR, grade_floors, grade_levels
from casadi_sins.model.noise import SensorNoise
from casadi_sins.model.parameters import ParameterSet, offset_free_covariance, separation
from casadi_sins.model.registry import NAMES, group_of


def test_a_navigation_grade_unit_keeps_the_navigation_grade_levels(kang_nlp):
    """The paper's unit resolves the Earth rate: it is judged by its groups' navigation-grade levels."""
    determined = next(c for c in kang_nlp.checks if c.name == "parameters determined by the schedule")
    assert determined.detail.startswith("parameters whose sigma exceeds about 1 % of what is known")


def test_a_mems_unit_is_judged_by_what_its_noise_could_give(hand_sim):
    """An Xsens-class unit (90 ug/sqrt(Hz), 1.9 deg/sqrt(h)): levels far above the navigation-grade ones, each
    GRADE_FACTOR times a floor that falls with the square root of the rest time."""
    noise = SensorNoise.from_natural({"gyro_arw_deg_rth": 1.9, "accel_vrw_ug_rthz": 90.0})
    levels = grade_levels(NAMES, noise, hand_sim.recording)
    assert levels["accel_bias_x"] > 100 * group_of("accel_bias_x").weak_level
    assert levels["gyro_bias_x"] > 1000 * group_of("gyro_bias_x").weak_level
    floors = grade_floors(NAMES, noise, 100.0, 9.8)
    assert np.isclose(floors["gyro_bias_x"], 1.9 * 60.0 / 10.0)  # ARW over 100 s: deg/h
    assert np.isclose(grade_floors(NAMES, noise, 400.0, 9.8)["accel_scale_y"], floors["accel_scale_y"] / 2.0)
    assert levels["gyro_scale_z"] == GRADE_FACTOR * grade_floors(
        NAMES, noise, sum(s.end - s.start for s in hand_sim.recording.static_segments), hand_sim.recording.site.g
    )["gyro_scale_z"]


def test_a_bias_tied_to_its_scale_by_an_offset_is_separated_at_that_scale():
    """Raw counts: B = S x offset / dt, so their errors are correlated to 0.9999; at the scale factor the bias keeps
    only its own uncertainty, and no pair is said inseparable."""
    values = np.zeros(21)
    values[:3] = 80.0  # m/s^2: 8 g of offset
    values[3:6] = 2.4e-5
    values[12:15] = 2.1e-6
    values[9:12] = 1e-6  # rad/s: no offset on the gyros here
    rng = np.random.default_rng(0)
    sigma_scale = 1e-4 * values[3:6]
    cov = np.diag(np.full(21, 1e-14))
    own = rng.uniform(1e-4, 2e-4, 3)  # the bias's own part, m/s^2
    for i in range(3):
        cov[i, i] = (80.0 / 2.4e-5 * sigma_scale[i]) ** 2 + own[i] ** 2
        cov[i, 3 + i] = cov[3 + i, i] = 80.0 / 2.4e-5 * sigma_scale[i] ** 2
        cov[3 + i, 3 + i] = sigma_scale[i] ** 2
    params = ParameterSet(values, covariance=cov)
    raw = cov[0, 3] / np.sqrt(cov[0, 0] * cov[3, 3])
    assert raw > 0.99  # the raw correlation
    free = offset_free_covariance(params)
    assert np.allclose(np.sqrt(np.diag(free)[:3]), own)
    assert not separation(params).correlated
    zero_bias = ParameterSet(np.where(np.arange(21) < 3, 0.0, values), covariance=np.diag(np.full(21, 1e-10)))
    assert np.allclose(offset_free_covariance(zero_bias), zero_bias.covariance)
