"""The overlapping Allan variance streamed in bounded memory: the same numbers as allantools, whatever the
chunks; the estimate's variance under a model against the textbook counts and a Monte Carlo."""

import numpy as np
import pytest

from casadi_sins.noise.allan import (BlockSums, StreamingAllan, allan_curve, confidence_interval, estimate_variance,
                                     overlapping_avar)
from casadi_sins.noise.terms import AxisTerms

allantools = pytest.importorskip("allantools")


def _streamed(x, chunk, limit):
    short, blocks = StreamingAllan(x.shape[1]), BlockSums(x.shape[1], limit=limit)
    for start in range(0, len(x), chunk):
        short.add(x[start:start + chunk])
        blocks.add(x[start:start + chunk])
    return short, blocks


def _allantools(x, dt, spacing, tau):
    """allantools' overlapping Allan deviation of the means of blocks of ``spacing`` (the estimate's starts)."""
    b = int(round(spacing / dt))
    blocks = x[:len(x) // b * b].reshape(-1, b).sum(axis=1)
    _, adev, _, terms = allantools.oadev(blocks / spacing, rate=1.0 / spacing, data_type="freq", taus=[tau])
    return adev[0], int(terms[0])


def test_streamed_allan_deviation_is_allantools_at_every_cluster_time(static_increments):
    dt = 0.01
    x = static_increments(100.0, 400.0, [0.3, 0.2], [0.05, 0.0], [0.0, 0.05], 30.0, seed=1, mean=[3.0, -7.0])
    short, blocks = _streamed(x, 7777, limit=5000)
    curve = allan_curve(short, blocks, dt)
    assert blocks.size == 8 and curve.tau[-1] > 150.0  # the blocks doubled; cluster times reach half the record
    checked = 0
    for k, (tau, spacing, terms) in enumerate(zip(curve.tau, curve.spacing, curve.terms)):
        if terms < 2:
            continue
        for axis in range(2):
            adev, count = _allantools(x[:, axis], dt, spacing, tau)
            assert count == terms
            assert np.sqrt(curve.avar[k, axis]) == pytest.approx(adev, rel=1e-10)
        checked += 1
    assert checked > 30 and np.all(np.diff(curve.tau) > 0)


def test_the_chunks_do_not_change_the_sums(static_increments):
    x = static_increments(50.0, 200.0, [1.0, 2.0, 3.0], seed=2)
    a_short, a_blocks = _streamed(x, len(x), limit=1000)
    b_short, b_blocks = _streamed(x, 333, limit=1000)
    a, b = allan_curve(a_short, a_blocks, 0.02), allan_curve(b_short, b_blocks, 0.02)
    np.testing.assert_allclose(a.avar, b.avar, rtol=1e-10)
    np.testing.assert_array_equal(a.terms, b.terms)
    size = a_blocks.size
    np.testing.assert_allclose(b_blocks.sums, x[:len(x) // size * size].reshape(-1, size, 3).sum(axis=1), rtol=1e-12)


def test_estimate_variance_of_white_noise_is_the_textbook_count():
    """Starts every sample at one sample (m = 1): 2K/3 degrees of freedom exactly; long cluster times Greenhall's."""
    n = 100_000
    expected, variance = estimate_variance(AxisTerms(1.0), 1, 1.0, n - 2)
    assert expected == pytest.approx(1.0)
    assert 2 * expected**2 / variance == pytest.approx(2 * (n - 2) / 3, rel=1e-4)
    for m in (300, 3000):
        expected, variance = estimate_variance(AxisTerms(1.0), m, 1.0, n - 2 * m)
        greenhall = allantools.edf_greenhall(alpha=0, d=2, m=m, N=n, overlapping=True, modified=False)
        assert 2 * expected**2 / variance == pytest.approx(greenhall, rel=0.01)


def test_estimate_variance_agrees_with_a_monte_carlo(static_increments):
    """White, quantization and a Gauss-Markov rate together; 400 records of 2000 samples."""
    terms = AxisTerms(1.0, 0.4, 0.3, 50.0)
    x = static_increments(1.0, 2000.0 * 400, 1.0, 0.4, 0.3, 50.0, seed=3).reshape(400, 2000).T
    for span in (1, 8, 100):
        avar, count = overlapping_avar(x, [span], 1.0)
        expected, variance = estimate_variance(terms, span, 1.0, int(count[0]))
        assert avar.mean() == pytest.approx(expected, rel=4 * np.sqrt(variance / 400) / expected)
        # the sample variance of 400 estimates: within about 4 of its standard errors (kurtosis of a few)
        assert avar.var() == pytest.approx(variance, rel=0.3)


def test_confidence_interval_is_the_chi_square_one():
    low, high = confidence_interval(np.array([2.0, 2.0]), np.array([1.0, 10.0]), level=0.6827)
    np.testing.assert_allclose(low, 2.0 * np.array([1.0, 10.0]) / np.array([1.98705, 14.3256]), rtol=1e-4)
    np.testing.assert_allclose(high, 2.0 * np.array([1.0, 10.0]) / np.array([0.0400668, 5.68055]), rtol=1e-4)
