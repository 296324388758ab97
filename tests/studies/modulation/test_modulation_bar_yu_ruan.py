"""The bar of Yu and Ruan 2014, section 3: the improved 16-order scheme against the common one.

The paper's simulation is one run with fixed error values (its sheet, +1 sigma on every term here: the
deterministic run), 20 deg/s, 45 s per position; its length is not stated (24 h here, as its turntable
test).  The covariance gives the same picture (docs/modulation.md)."""

import numpy as np
import pytest

from casadi_sins.core import units
from casadi_sins.studies.modulation.covariance import propagate
from casadi_sins.studies.modulation.residual import integrated_error
from casadi_sins.studies.modulation.schemes import load_scheme
from casadi_sins.studies.modulation import model as M

NMI = 1852.0


@pytest.fixture(scope="module")
def det(yu_ruan_sheet, yu_ruan_site):
    out = {}
    for name in ("yu-ruan2014-common", "yu-ruan2014-improved"):
        prop = propagate(load_scheme(name), yu_ruan_site, 24.0, yu_ruan_sheet.gyro_arw, yu_ruan_sheet.accel_vrw)
        m = prop.mean(yu_ruan_sheet.values())
        out[name] = (np.hypot(m[:, 2], m[:, 3]).max() / NMI, np.hypot(m[:, 0], m[:, 1]).max())
    return out


def test_improved_position_error_within_2x_of_0_4_nmi(det):
    assert 0.2 <= det["yu-ruan2014-improved"][0] <= 0.8


@pytest.mark.xfail(strict=True, reason="measured 0.205 m/s (common 0.416): the ratio 0.49 is the paper's (0.5 against "
                   "1 m/s), the absolute level about 0.4 of it, like the position (docs/modulation.md)")
def test_improved_velocity_error_within_2x_of_0_5_mps(det):
    assert 0.25 <= det["yu-ruan2014-improved"][1] <= 1.0


@pytest.mark.xfail(strict=True, reason="measured 0.350 nmi for the common scheme (0.217 improved): the ratio is "
                   "the paper's, the absolute level about half of it: alignment, run length, start phase and sign "
                   "pattern ruled out; the errors at twice their stated size give 0.70/0.43 nmi (docs/modulation.md)")
def test_common_position_error_within_2x_of_0_74_nmi(det):
    assert 0.37 <= det["yu-ruan2014-common"][0] <= 1.48


def test_improved_over_common_at_most_0_7(det):
    """The bar: the published (PSINS) order of the improved scheme, 0.62 here (velocity 0.49, the paper about 0.5)."""
    assert det["yu-ruan2014-improved"][0] / det["yu-ruan2014-common"][0] <= 0.7


def test_improved_over_common_velocity_about_one_half(det):
    """The paper: improved 0.5 m/s against common 1 m/s."""
    assert 0.35 <= det["yu-ruan2014-improved"][1] / det["yu-ruan2014-common"][1] <= 0.65


def test_improved_scheme_oscillates_less(yu_ruan_sheet, yu_ruan_site):
    """Fig. 6: the integral of the gyro errors in the geographic frame oscillates less under the improved
    scheme (north and up peak-to-peak over two periods)."""
    x = yu_ruan_sheet.values()[M.N_NAV:]
    pp = {}
    for name in ("yu-ruan2014-common", "yu-ruan2014-improved"):
        scheme = load_scheme(name)
        _, theta = integrated_error(scheme, yu_ruan_site, x, 2 * scheme.period / 3600.0, step_s=3.0)
        pp[name] = (theta.max(0) - theta.min(0)) / units.ARCSEC
    assert np.all(pp["yu-ruan2014-improved"][1:] < 0.8 * pp["yu-ruan2014-common"][1:])
