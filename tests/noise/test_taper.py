"""Tapered gyro means on a swaying base (noise.taper): the window, its weights, the lines and the leakage bound."""

from __future__ import annotations

import numpy as np
import pytest

from casadi_sins.noise import taper as T

STEP = 0.1
N = 999  # the rates over a 100 s segment's steps after its first


def test_the_window_is_the_first_slepian_sequence():
    from scipy.signal.windows import dpss

    for n, nw in ((N, 4.5), (100, 3.0)):
        reference = np.abs(dpss(n, nw))
        assert np.max(np.abs(T.window(n, nw) - reference / reference.max())) < 1e-9


def test_the_tapered_mean_of_a_turning_attitude_is_its_rate_whatever_its_offset():
    steps = np.full(1000, STEP) * (1.0 + 0.01 * np.sin(np.arange(1000)))  # unequal steps, as plan_steps cuts them
    u = T.rate_weights(steps, 5.0)
    c = T.point_coefficients(u)
    assert u[0] == 0.0 and np.sum(u * steps) == pytest.approx(1.0) and np.sum(c) == pytest.approx(0.0, abs=1e-12)
    ends = np.cumsum(steps)
    assert c @ (3.0 + 2.5e-7 * ends) == pytest.approx(2.5e-7, rel=1e-9)


def sinusoids(periods, amplitudes, phases, n=N, step=STEP):
    t = (np.arange(n) + 0.5) * step
    return sum(a * np.cos(2 * np.pi * t / p + f) for p, a, f in zip(periods, amplitudes, phases))


def test_close_lines_are_found_and_their_frequencies_refined():
    rate = np.column_stack([sinusoids((6.0, 5.75), (1e-4, 6e-5), (0.3, 1.0)), sinusoids((11.0,), (8e-5,), (2.0,)),
                            np.zeros(N)])
    lines = T.rate_lines(rate, np.full(3, 1e-20))
    found = np.sort(lines.cycles)
    assert np.allclose(found, np.sort([N * STEP / 6.0, N * STEP / 5.75, N * STEP / 11.0]), atol=0.02)
    assert np.max(np.abs(lines.remainder)) < 1e-3 * 1e-4


def test_the_leakage_bound_covers_a_sway_and_the_window_is_chosen_below_its_slowest_period():
    """A sway of 20-63 arcsec at 3-17 s (its rate) with the paper's gyro noise: the chosen window leaks less than
    its bound says (as a variance over the lines' phases: within 3 times in amplitude), far below the noise."""
    rng = np.random.default_rng(3)
    arw = np.full(3, 0.01 * np.pi / 180 / 3600 * np.sqrt(0.01))  # rad/s/sqrt(Hz): 0.01 deg/h per 100 Hz sample
    worst = 0.0
    for _ in range(5):
        periods = np.exp(rng.uniform(np.log(3.0), np.log(17.0), (3, 2)))
        amplitude = rng.uniform(20.0, 63.0, (3, 2)) * np.pi / 180 / 3600
        motion = np.column_stack([sinusoids(p, a * 2 * np.pi / p, rng.uniform(0, 6.3, 2))
                                  for p, a in zip(periods, amplitude)])
        noise = rng.standard_normal((N, 3)) * arw / np.sqrt(STEP)
        choice = T.choose_taper(motion + noise, STEP, arw)
        weights = T.window(N, choice.nw) / T.window(N, choice.nw).sum()
        leak = np.abs(weights @ motion)
        assert choice.nw <= N * STEP / periods.max()  # the slowest sway lies beyond the window's main lobe
        worst = max(worst, float(np.max(leak / np.sqrt(choice.leakage + 1e-300))))
        noise_sigma = arw * np.sqrt(choice.noise_factor / (N * STEP))
        assert np.all(np.sqrt(choice.leakage) < noise_sigma) and 1.5 < choice.noise_factor < 2.5
    assert worst < 3.0


def test_motion_slower_than_two_cycles_is_not_told_from_a_bias_and_a_ramp_is_not_motion():
    t = (np.arange(N) + 0.5) * STEP
    rate = np.column_stack([1e-6 + 1e-9 * t, np.zeros(N), np.zeros(N)])
    lines = T.rate_lines(rate, np.full(3, 1e-24))
    assert len(lines.cycles) == 0 or np.all(lines.power[:, 0] < 1e-24)
    weights = T.window(N, 4.0) / T.window(N, 4.0).sum()
    assert np.all(T.leakage_variance(lines, np.full(3, 1e-24), weights) < 1e-24)
