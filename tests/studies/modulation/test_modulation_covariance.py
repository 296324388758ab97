"""The covariance propagation: discretisation, the split by source, agreement with the package's budget
and alignment."""

import time

import numpy as np
import pytest

from casadi_sins.core.errors import InputError
from casadi_sins.model.registry import NAMES
from casadi_sins.studies import budget as B
from casadi_sins.studies.modulation import model as M
from casadi_sins.studies.modulation import sources as S
from casadi_sins.studies.modulation.analysis import run_scheme
from casadi_sins.studies.modulation.covariance import propagate
from casadi_sins.studies.modulation.schemes import load_scheme


def test_independent_sources_add_up_to_the_total(guan_sheet, guan_site):
    res = run_scheme(load_scheme("dual-axis-16"), guan_sheet, guan_site, 6.0)
    summed = sum(res.by_source.values())
    np.testing.assert_allclose(summed, res.total, rtol=1e-9, atol=1e-9)


def test_correlations_of_a_table_stay_in_the_total(guan_sheet, guan_site):
    """A correlation across groups (a calibrated table's) is in the total, not in the split: the total
    differs from the sum of the sources by exactly the cross term."""
    p0 = guan_sheet.p0.copy()
    i, j = M.INDEX["gyro_bias_y"], M.INDEX["phi_U"]
    p0[i, j] = p0[j, i] = -0.9 * np.sqrt(p0[i, i] * p0[j, j])
    corr = S.Sources("corr", p0, guan_sheet.gyro_arw, guan_sheet.accel_vrw, correlated=True)
    res = run_scheme(load_scheme("strapdown"), corr, guan_site, 24.0)
    cross = np.zeros_like(p0)
    cross[i, j] = cross[j, i] = p0[i, j]
    expected = sum(res.by_source.values()) + res.propagation.covariance(cross, noises=())
    np.testing.assert_allclose(res.total, expected, rtol=1e-9, atol=1e-6)
    assert np.abs(res.propagation.covariance(cross, noises=())[:, 3, 3]).max() > 1e5  # m^2: it matters


def test_turn_discretisation_converges(guan_sheet, guan_site):
    """Magnus (4th order) on 22.5 deg and 5 deg sub-steps against 2 deg (1 h of the dual-axis scheme)."""
    scheme = load_scheme("dual-axis-16")
    ref = propagate(scheme, guan_site, 1.0, guan_sheet.gyro_arw, guan_sheet.accel_vrw, step_deg=2.0)
    r = np.sqrt(ref.covariance(guan_sheet.p0)[:, 3, 3])
    for step, tol in ((5.0, 1e-6), (22.5, 1e-3)):
        prop = propagate(scheme, guan_site, 1.0, guan_sheet.gyro_arw, guan_sheet.accel_vrw, step_deg=step)
        p = np.sqrt(prop.covariance(guan_sheet.p0)[:, 3, 3])
        assert np.abs(p - r).max() < tol * r.max()


@pytest.mark.parametrize("step,message", [(30.0, "too few steps per turn"), (0.001, "below 0.01 deg"),
                                          (float("nan"), "too few steps per turn")])
def test_a_turn_step_out_of_range_is_refused(guan_sheet, guan_site, step, message):
    with pytest.raises(InputError, match=message):
        propagate(load_scheme("dual-axis-16"), guan_site, 1.0, guan_sheet.gyro_arw, guan_sheet.accel_vrw,
                  step_deg=step)


def test_a_72_h_dual_axis_run_takes_under_60_s(guan_sheet, guan_site):
    start = time.perf_counter()
    res = run_scheme(load_scheme("dual-axis-16"), guan_sheet, guan_site, 72.0)
    assert time.perf_counter() - start < 60.0
    assert res.propagation.time[-1] == pytest.approx(72 * 3600.0)


@pytest.mark.parametrize("name,size", [("gyro_bias_y", np.radians(0.01) / 3600), ("gyro_scale_z", 1e-5),
                                       ("gyro_misalign_zy", 3 * np.pi / 648000), ("accel_bias_x", 30e-6 * 9.80665)])
def test_strapdown_matches_the_package_budget(guan_site, name, size):
    """The same mean error of one parameter error as :func:`casadi_sins.studies.budget.propagate_mean`."""
    e = np.zeros(len(NAMES))
    e[NAMES.index(name)] = size
    t, pred = B.propagate_mean(e, np.eye(3), guan_site.latitude, 0.0, guan_site.g, 100.0, 86400.0)
    model = M.ErrorModel(guan_site, M.SHEET_NAMES)
    x0 = np.zeros(model.n_state)
    x0[:3] = model.alignment_map(np.eye(3))[:, :len(NAMES)] @ e
    x0[M.N_NAV:M.N_NAV + len(NAMES)] = e
    prop = propagate(load_scheme("strapdown"), guan_site, 24.0, np.zeros(3), np.zeros(3))
    ours = prop.mean(x0)
    for col in (0, 1):
        np.testing.assert_allclose(np.interp(t, prop.time, ours[:, 2 + col]), pred[:, col], atol=1e-6)
