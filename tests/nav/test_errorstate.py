"""The static-base navigation error block: its natural frequencies are those of free-inertial navigation."""

import numpy as np
import pytest

from casadi_sins.core.earth import EARTH_RATE, Site, earth_radii
from casadi_sins.nav.errorstate import N_NAV, navigation_block, with_sensor_inputs


@pytest.mark.parametrize("latitude_deg", [-60.0, 10.0, 45.77, 70.0])
def test_frequencies_are_earth_rate_and_schuler_split_by_foucault(latitude_deg):
    site = Site(np.radians(latitude_deg))
    freq = np.sort(np.abs(np.linalg.eigvals(navigation_block(site.latitude, 0.0, site.g)).imag))
    schuler = np.sqrt(site.g / np.sqrt(np.prod(earth_radii(site.latitude))))
    foucault = EARTH_RATE * abs(np.sin(site.latitude))
    np.testing.assert_allclose(freq[1:3], EARTH_RATE, rtol=1e-9)
    np.testing.assert_allclose(freq[3:5], schuler - foucault, rtol=2e-3)
    np.testing.assert_allclose(freq[5:7], schuler + foucault, rtol=2e-3)


def test_sensor_inputs_fill_only_their_columns():
    site = Site(np.radians(45.0))
    nav = navigation_block(site.latitude, 100.0, site.g, N_NAV + 4)
    rng = np.random.default_rng(0)
    gyro, accel = rng.normal(size=(3, 4)), rng.normal(size=(3, 4))
    f = with_sensor_inputs(nav, gyro, accel)
    np.testing.assert_array_equal(f[:, :N_NAV], nav[:, :N_NAV])
    np.testing.assert_array_equal(f[0:3, N_NAV:], -gyro)
    np.testing.assert_array_equal(f[3:5, N_NAV:], accel[:2])
    assert not f[5:, N_NAV:].any()
