"""The bar of Guan et al. 2023, section 4.1 (Table 1 sheet, 24 h, static base, latitude 34.25 deg)."""

import numpy as np
import pytest

from casadi_sins.studies.modulation import model as M
from casadi_sins.studies.modulation.analysis import run_scheme
from casadi_sins.studies.modulation.schemes import load_scheme


def lon_max(cov):
    return np.sqrt(cov[:, 3, 3]).max()


@pytest.fixture(scope="module")
def runs(guan_sheet, guan_site):
    return {name: run_scheme(load_scheme(name), guan_sheet, guan_site, 24.0)
            for name in ("strapdown", "single-axis-reciprocating", "dual-axis-16")}


def test_strapdown_longitude_error_about_23000_m(runs):
    """Fig. 1: the longitude error's maximum is about 23 000 m (here 22 227 m)."""
    assert lon_max(runs["strapdown"].total) == pytest.approx(23000.0, rel=0.15)


def test_single_axis_longitude_error_about_13000_m(runs):
    """Figs. 1-2: single-axis rotation brings it to 13 000 m (here 12 493 m)."""
    assert lon_max(runs["single-axis-reciprocating"].total) == pytest.approx(13000.0, rel=0.15)


def test_single_axis_initial_attitude_contribution_equals_strapdown(runs):
    """Fig. 2: rotation can do nothing against the initial attitude errors."""
    for group in ("initial level", "initial heading"):
        turning = lon_max(runs["single-axis-reciprocating"].by_source[group])
        still = lon_max(runs["strapdown"].by_source[group])
        assert turning == pytest.approx(still, rel=0.01)


def test_single_axis_removes_the_horizontal_gyro_biases_not_the_vertical(runs, guan_sheet):
    """Fig. 3: the x, y gyro biases' contribution goes to about zero, the z one is unchanged."""
    def bias(result, axes):
        p = np.zeros_like(guan_sheet.p0)
        idx = [M.INDEX[f"gyro_bias_{a}"] for a in axes]
        p[idx, idx] = guan_sheet.p0[idx, idx]
        return lon_max(result.propagation.covariance(p, noises=()))

    turning, still = runs["single-axis-reciprocating"], runs["strapdown"]
    assert bias(turning, "xy") < 0.01 * bias(still, "xy")
    assert bias(turning, "z") == pytest.approx(bias(still, "z"), rel=0.01)


def test_dual_axis_gyro_biases_are_negligible_against_the_total(runs):
    """Fig. 4, qualitatively: the three gyro biases are negligible against the total (here 15 m of 2 886 m),
    bounded (no growth over the day), and below 0.1 % of their strapdown contribution."""
    res = runs["dual-axis-16"]
    bias = np.sqrt(res.by_source["gyro bias"][:, 3, 3])
    assert bias.max() < 0.01 * lon_max(res.total)
    assert bias.max() < 0.001 * lon_max(runs["strapdown"].by_source["gyro bias"])
    assert bias[res.propagation.time > 12 * 3600].max() < 1.5 * bias[res.propagation.time <= 12 * 3600].max()


@pytest.mark.xfail(strict=True, reason="measured 15.2 m with the 16-position scheme at 20 deg/s and 45 s per stop "
                   "(the only timing in the two papers), navigation starting with a turn; the bound term scales with the "
                   "stop length (7.7 m at 20 s) and with the start phase (7.7 m when navigation starts half a "
                   "stop before the first turn), see docs/modulation.md; Guan et al. state neither")
def test_dual_axis_gyro_biases_a_few_metres(runs):
    """Fig. 4: 'only a few metres' (bar: <= 10 m)."""
    assert lon_max(runs["dual-axis-16"].by_source["gyro bias"]) <= 10.0
