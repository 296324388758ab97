"""Noise identification against an independent generator (white noise, quantization and a first-order
Gauss-Markov rate written with NumPy in tests/conftest.py): the truth within the fit's own uncertainty, at
several rates, noise levels, correlation times from 100 s to 3000 s and Gauss-Markov sigmas from 0.3 to 3 times
the white noise's Allan deviation at the correlation time; bounds that hold where a term cannot be fitted."""

import math

import numpy as np
import pytest

from casadi_sins.noise.identify import fit_axis, identify
from casadi_sins.noise.rest import rest_record

#: A standard error's multiple within which a fitted term must meet the truth (the cases use fixed seeds).
Z = 4.0


def _fit(increments, rate_hz):
    record = rest_record(increments, rate_hz)
    return fit_axis(record.periodograms, 0, record.duration, record.dt)


def _truth(white, floor_ratio, tau, quantization_ratio, rate_hz):
    """``(N, Q, sigma)``: sigma as a multiple of the white noise's Allan deviation at ``tau``, ``N / sqrt(tau)``;
    Q as a multiple of the white noise per sample."""
    return white, quantization_ratio * white / math.sqrt(rate_hz), floor_ratio * white / math.sqrt(tau)


def _check_white_and_quantization(fit, white, quantization):
    assert 0 < fit.white.sigma < 0.01 * white
    assert abs(fit.white.value - white) <= Z * fit.white.sigma
    if fit.quantization.kind == "fitted":
        assert abs(fit.quantization.value - quantization) <= Z * fit.quantization.sigma
    else:
        assert quantization <= fit.quantization.value


CASES = [  # rate Hz, hours, white, sigma / Allan floor at tau, tau s, quantization / white per sample, seed
    (10.0, 8.0, 1.0, 3.0, 100.0, 0.3, 1),
    (20.0, 8.0, 2e-3, 1.0, 300.0, 0.0, 2),
    (5.0, 8.0, 15.0, 3.0, 1000.0, 1.0, 3),
    (2.0, 8.0, 1.0, 3.0, 3000.0, 0.0, 4),
    (50.0, 2.0, 0.7, 0.3, 100.0, 0.5, 5),
    (4.0, 8.0, 1.0, 2.0, 600.0, 2.0, 6),
]


@pytest.mark.parametrize("rate, hours, white, ratio, tau, q_ratio, seed", CASES)
def test_recovers_the_terms_within_their_uncertainty_or_bounds_them(static_increments, rate, hours, white, ratio, tau,
                                                                     q_ratio, seed):
    white, quantization, sigma = _truth(white, ratio, tau, q_ratio, rate)
    x = static_increments(rate, hours * 3600.0, white, quantization, sigma, tau, seed=seed, mean=5.0 * white)
    fit = _fit(x, rate)
    _check_white_and_quantization(fit, white, quantization)
    if fit.status == "determined":
        assert abs(math.log(fit.gm_sigma.value / sigma)) <= Z * fit.gm_sigma.sigma / fit.gm_sigma.value
        assert abs(math.log(fit.gm_tau.value / tau)) <= Z * fit.gm_tau.sigma / fit.gm_tau.value
        assert fit.gm_tau.low < fit.gm_tau.value < fit.gm_tau.high
    elif fit.status == "tau beyond reach":  # bounds: tau at least, sigma at least its value there
        assert fit.gm_tau.kind == "lower bound" and fit.gm_tau.value <= tau
        assert fit.gm_sigma.kind == "lower bound" and fit.gm_sigma.value <= 1.3 * sigma
    else:
        assert fit.gm_sigma.kind == "upper bound" and sigma <= fit.gm_sigma.value
    if ratio >= 3.0 and tau <= 1000.0:  # plainly visible in 8 h: seen and its time bounded
        assert fit.status == "determined"
    if ratio <= 0.3:
        assert fit.status == "not detected"
    assert fit.check.passed


def test_a_record_shorter_than_the_correlation_time_says_so_and_bounds_it(static_increments):
    """One hour of a bias wandering with a correlation time of 3000 s: tau at least, sigma at least."""
    white, _, sigma = _truth(1.0, 3.0, 3000.0, 0.0, 10.0)
    fit = _fit(static_increments(10.0, 3600.0, white, 0.0, sigma, 3000.0, seed=7), 10.0)
    assert fit.status in ("tau beyond reach", "not detected")
    if fit.status == "tau beyond reach":
        assert fit.gm_tau.value <= 3000.0 and fit.gm_sigma.value <= sigma
        assert fit.rate_random_walk == pytest.approx(sigma * math.sqrt(2 / 3000.0), rel=0.5)
    else:
        assert fit.gm_sigma.value >= sigma


def test_white_noise_alone_is_not_taken_for_a_bias(static_increments):
    x = static_increments(20.0, 4 * 3600.0, [1.0, 1.0, 1.0], seed=8)
    result = identify(rest_record(x, 20.0))
    assert all(f.status == "not detected" for f in result.fits)
    assert all(f.gm_sigma.kind == "upper bound" and f.gm_sigma.value > 0 for f in result.fits)


@pytest.mark.slow
def test_uncertainties_are_honest_over_many_records(static_increments):
    """24 records: the errors over their standard errors have unit RMS (white noise, sigma, log tau), and the
    profile's 95 % interval of tau holds the truth in most."""
    rate, tau = 2.0, 200.0
    white, _, sigma = _truth(1.0, 3.0, tau, 0.0, rate)
    z_white, z_sigma, z_tau, inside = [], [], [], []
    for seed in range(24):
        fit = _fit(static_increments(rate, 8 * 3600.0, white, 0.0, sigma, tau, seed=100 + seed), rate)
        assert fit.status == "determined"
        z_white.append((fit.white.value - white) / fit.white.sigma)
        z_sigma.append(math.log(fit.gm_sigma.value / sigma) / (fit.gm_sigma.sigma / fit.gm_sigma.value))
        z_tau.append(math.log(fit.gm_tau.value / tau) / (fit.gm_tau.sigma / fit.gm_tau.value))
        inside.append(fit.gm_tau.low <= tau <= fit.gm_tau.high)
    for z in (z_white, z_sigma, z_tau):  # RMS of 24 unit normals: 0.72 .. 1.28 with 99 % probability
        assert 0.6 < float(np.sqrt(np.mean(np.square(z)))) < 1.4
    assert np.mean(inside) >= 0.8


def test_identify_in_si_scales_every_amplitude(static_increments):
    x = static_increments(10.0, 3600.0, [1.0, 2.0], 0.1, [0.05, 0.0], 100.0, seed=9)
    pulses = identify(rest_record(x, 10.0))
    si = pulses.scaled([1e-6, 3e-4])
    for fit, scaled, factor in zip(pulses.fits, si.fits, (1e-6, 3e-4)):
        assert scaled.white.value == pytest.approx(factor * fit.white.value)
        assert scaled.gm_sigma.value == pytest.approx(factor * fit.gm_sigma.value)
        assert scaled.terms.gm_tau == fit.terms.gm_tau
    np.testing.assert_allclose(si.allan.adev, pulses.allan.adev * [1e-6, 3e-4])
