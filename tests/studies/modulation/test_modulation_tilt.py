"""The period-mean tilt: its 2 R x horizontal part predicts the covariance's Schuler swing."""

import numpy as np
import pytest

from casadi_sins.studies.modulation import model as M
from casadi_sins.studies.modulation.analysis import horizontal
from casadi_sins.studies.modulation.covariance import propagate
from casadi_sins.studies.modulation.schemes import load_scheme
from casadi_sins.studies.modulation.tilt import mean_tilt, mean_tilt_table


@pytest.mark.parametrize("name", ["yu-ruan2014-common", "yu-ruan2014-improved"])
def test_two_r_mean_tilt_predicts_the_first_hours_maximum(name, yu_ruan_sheet, yu_ruan_site):
    """Before the scale x Earth-rate drift ramps (first 1.5 h), the covariance's maximum is 2 R x the
    period-mean horizontal tilt of all terms, to a few per cent."""
    scheme = load_scheme(name)
    prop = propagate(scheme, yu_ruan_site, 1.5, yu_ruan_sheet.gyro_arw, yu_ruan_sheet.accel_vrw)
    cov_max = horizontal(prop.covariance(yu_ruan_sheet.initial_covariance)).max()
    predicted = mean_tilt_table(scheme, yu_ruan_sheet, yu_ruan_site)["two_r_horizontal_total_m"]
    assert predicted == pytest.approx(cov_max, rel=0.03)


def test_a_constant_initial_tilt_is_its_own_mean(yu_ruan_site):
    m = mean_tilt(load_scheme("yu-ruan2014-improved"), yu_ruan_site)
    assert np.allclose(m[:, M.PHI], np.eye(3))
    assert np.all(m[:, 3:M.N_NAV] == 0)


def test_the_axis_swap_halves_the_table_rate_misalignment_tilt(yu_ruan_site):
    """The published improved order swaps the axes in orders 9-16: the y gyro's z-turn misalignment
    (t_yz) leaves half the mean tilt of the common scheme's, or less."""
    col = M.INDEX["gyro_misalign_yz"]
    common = mean_tilt(load_scheme("yu-ruan2014-common"), yu_ruan_site)[:2, col]
    improved = mean_tilt(load_scheme("yu-ruan2014-improved"), yu_ruan_site)[:2, col]
    assert np.hypot(*improved) <= 0.5 * np.hypot(*common)
