"""Whittle's likelihood and its solvers: the exact non-negative least squares, the maximum of the likelihood
and its Fisher information against draws of exponential and gamma ordinates."""

import numpy as np

from casadi_sins.noise.spectrum import Periodogram
from casadi_sins.noise.whittle import Ordinates, fisher_information, fit_linear, inverse_information, \
    nonnegative_least_squares


def test_nonnegative_least_squares_is_scipys():
    from scipy.optimize import nnls
    rng = np.random.default_rng(0)
    for _ in range(50):
        a = rng.standard_normal((30, 3))
        b = rng.standard_normal(30)
        np.testing.assert_allclose(nonnegative_least_squares(a, b), nnls(a, b)[0], atol=1e-10)


def test_the_maximum_likelihood_and_its_fisher_errors_match_draws():
    """White noise and quantization (S = 0.3 N^2 + 2 Q^2 (1 - cos w)), 2000 ordinates in bins of 1 to 4, 300
    draws: the estimates' mean is the truth, their spread the inverse Fisher information's."""
    rng = np.random.default_rng(1)
    n = 4001
    omega = 2 * np.pi * np.arange(1, 2001) / n
    weight = rng.integers(1, 5, size=2000).astype(float)
    truth = np.array([2.0, 0.5])
    estimates, spreads = [], []
    for _ in range(300):
        expected = truth[0] * 0.3 + truth[1] * 2 * (1 - (1 - 1 / n) * np.cos(omega))
        power = rng.gamma(weight, expected[:, None].T[0] / weight)[:, None]
        data = Ordinates([Periodogram(omega, weight, power, 0.3, n)], 0)
        theta, _, fitted = fit_linear(data, data.base)
        estimates.append(theta)
        spreads.append(np.sqrt(np.diag(inverse_information(fisher_information(data, data.base, fitted)))))
    estimates = np.array(estimates)
    np.testing.assert_allclose(estimates.mean(axis=0), truth, rtol=0.02)
    np.testing.assert_allclose(estimates.std(axis=0), np.mean(spreads, axis=0), rtol=0.15)
