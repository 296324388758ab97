"""The closed forms of the noise terms: Allan variance, structure function and spectrum agree with each other
and with their limits."""

import numpy as np
import pytest

from casadi_sins.noise.allan import estimate_variance
from casadi_sins.noise.terms import (GM_PEAK_FRACTION, GM_PEAK_TAU, AxisTerms, allan_variance, gauss_markov_allan,
                                     gauss_markov_column, spectrum_columns)


def test_gauss_markov_allan_variance_rises_as_a_random_walk_peaks_and_falls_as_white_noise():
    x = np.array([1e-6, 1e-3, 0.0099, 0.0101])
    series = 2.0 * x / 3.0 - x**2 / 2.0 + 7.0 * x**3 / 30.0 - x**4 / 12.0
    np.testing.assert_allclose(gauss_markov_allan(x), series, rtol=1e-8)  # series and closed form meet
    big = np.array([1e3, 1e5])
    np.testing.assert_allclose(gauss_markov_allan(big), 2.0 / big, rtol=2e-3)
    grid = np.geomspace(0.1, 10.0, 20001)
    k = np.argmax(gauss_markov_allan(grid))
    assert grid[k] == pytest.approx(GM_PEAK_TAU, rel=1e-3)
    assert np.sqrt(gauss_markov_allan(grid[k])) == pytest.approx(GM_PEAK_FRACTION, abs=1e-4)


@pytest.mark.parametrize("terms", [AxisTerms(0.3, 0.2), AxisTerms(0.3, 0.0, 0.05, 40.0), AxisTerms(0.0, 0.1, 0.2, 7.0)])
def test_allan_variance_is_the_second_difference_of_the_structure_function(terms):
    """E[avar] from the angle's structure function (any spacing) equals the closed form, term by term."""
    for span, spacing in ((1, 0.01), (3, 0.5), (40, 2.0), (7, 25.0)):
        expected, _ = estimate_variance(terms, span, spacing, 1000)
        assert expected == pytest.approx(float(terms.allan_variance(span * spacing)), rel=1e-9)


@pytest.mark.parametrize("length", [None, 64, 501])
def test_spectrum_columns_are_the_autocovariance_sums(length):
    """The spectrum (or expected periodogram of ``length`` sums) of the three terms, against sums over the lags of
    their autocovariances written out."""
    g, tau, n_lags = 0.5, 7.0, 4000
    omega = 2.0 * np.pi * np.array([1, 3, 10, 30, 31]) / (length or 64)
    x, a = g / tau, np.exp(-g / tau)
    lags = np.arange(1, n_lags)
    gm = np.concatenate([[2 * tau**2 * (x - 1 + a)], tau**2 * (1 - a) ** 2 * a ** (lags - 1)])
    quant = np.zeros(n_lags)
    quant[:2] = 2.0, -1.0
    weight = np.ones(n_lags) if length is None else np.clip(1.0 - np.arange(n_lags) / length, 0.0, None)

    def summed(gamma):
        return gamma[0] + 2.0 * np.array([np.sum(weight[1:] * gamma[1:] * np.cos(w * lags)) for w in omega])

    cols = spectrum_columns(omega, g, tau, length)
    np.testing.assert_allclose(cols[:, 0], g)
    np.testing.assert_allclose(cols[:, 1], summed(quant), rtol=1e-12)
    np.testing.assert_allclose(cols[:, 2], summed(gm), rtol=1e-9)


def test_gauss_markov_column_loses_no_digits_when_the_correlation_time_is_a_million_intervals():
    omega = np.array([2e-6, 1e-3, 3.0])
    for length in (None, 10**6):
        near = gauss_markov_column(omega, 0.04, 4e4, length)
        assert np.all(np.isfinite(near)) and np.all(near > 0)
    # the white-noise limit: S(0) = 2 sigma^2 T g for sums over g
    assert gauss_markov_column(np.array([1e-12]), 0.04, 4e4)[0] == pytest.approx(2 * 4e4 * 0.04, rel=1e-6)


def test_allan_variance_adds_the_terms():
    tau = np.array([0.01, 1.0, 100.0])
    total = allan_variance(tau, 0.2, 0.03, 0.01, 50.0)
    np.testing.assert_allclose(total, 3 * 0.03**2 / tau**2 + 0.04 / tau + 1e-4 * gauss_markov_allan(tau / 50.0))
