"""Linear base motion (noise.translation): the base's acceleration in the static specific force, and the decision."""

from __future__ import annotations

import numpy as np
import pytest

from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.core.rotations import rotation_matrices
from casadi_sins.noise.plan import plan_noise
from casadi_sins.noise.translation import MotionLine, base_acceleration, detrended, motion_bands

G = 9.8
DT = 0.01


def static_increments(force_n, sway, attitude):
    """Exact-enough increments of a body ``attitude @ exp(sway)`` under specific force ``force_n`` (per sample)."""
    t = np.arange(len(force_n)) * DT
    turn = rotation_matrices(sway)  # base sway in n
    body = np.swapaxes(turn @ attitude, -1, -2)
    dv = np.einsum("kij,kj->ki", body, force_n) * DT
    rate = np.gradient(sway, DT, axis=0)
    dtheta = np.einsum("kij,kj->ki", body, rate) * DT  # small sway: the body rate is the sway rate turned into b
    return dtheta, dv, t


def test_gravity_turned_by_the_sway_is_taken_out_and_a_heave_is_left():
    """A sway of 60 arcsec at 5 and 7 s leaves less than 1 ug; a heave of 14 mg at 4 s is found with its size."""
    n = 10000
    t = np.arange(n) * DT
    sway = 60 * np.pi / 180 / 3600 * np.column_stack([np.sin(2 * np.pi * t / 5.0), np.cos(2 * np.pi * t / 7.0 + 1),
                                                       0.5 * np.sin(2 * np.pi * t / 6.0)])
    attitude = rotation_matrices(np.array([0.3, -0.2, 1.0]))
    still = np.tile([0.0, 0.0, G], (n, 1))
    dtheta, dv, _ = static_increments(still, sway, attitude)
    left = detrended(base_acceleration(dtheta, dv, DT, 50))
    assert np.max(np.abs(left)) < 1e-5  # 1 ug; gravity turned by the sway is 3 mg
    heave = 0.14 * np.sin(2 * np.pi * t / 4.0)
    dtheta, dv, _ = static_increments(still + np.column_stack([0 * t, 0 * t, heave]), sway, attitude)
    accel = detrended(base_acceleration(dtheta, dv, DT, 50))
    assert 0.93 * 0.14 < np.max(np.linalg.norm(accel, axis=1)) < 0.14  # half-second means of a 4 s heave


def test_bands_cover_the_lines_and_merge_when_they_overlap():
    assert motion_bands([0.1, 0.3, 0.101], 0.01) == [(pytest.approx(0.09), pytest.approx(0.111)),
                                                       (pytest.approx(0.29), pytest.approx(0.31))]


def test_a_deck_is_found_with_its_periods_and_size_and_a_still_or_swaying_base_is_not(deck_sim, kang_sim, kang_problem):
    from casadi_sins.sim import simulate

    rec = deck_sim.recording
    linear = plan_noise(rec, rough_parameters(rec).values).linear
    assert linear.moving and "moved linearly" in linear.describe()
    truth = deck_sim.translation
    true_f = (truth.omega / 2 / np.pi)[truth.amplitude > 0]
    found = np.array([line.frequency_hz for line in linear.lines])
    assert all(np.min(np.abs(found - f)) < 1e-3 for f in true_f)
    peak = np.max(truth.amplitude * truth.omega**2)
    assert max(line.acceleration for line in linear.lines) == pytest.approx(peak, rel=0.05)
    assert max(line.amplitude for line in linear.lines) == pytest.approx(peak, rel=0.05)
    sway = simulate(kang_problem.with_changes(sway_amplitude_arcsec=(20.0, 63.0), sway_period_s=(3.0, 17.0)), seed=7)
    for still in (kang_sim.recording, sway.recording):
        assert not plan_noise(still, rough_parameters(still).values).linear.moving


def test_a_surge_between_two_body_axes_is_told_at_its_full_size():
    """A surge of 13.6 mg at a heading of 52 deg from a body axis shows 10.7 mg on the larger axis; the line's
    amplitude, displacement and velocity are those of the whole surge (an independent simulator's deck)."""
    surge, heading, f = 13.6e-3 * 9.80665, np.radians(52.0), 1.0 / 6.0
    axes = surge * np.abs([np.cos(heading), np.sin(heading)])
    line = MotionLine(1, f, float(axes.max()), vertical=0.0, horizontal=float(np.hypot(*axes)))
    assert line.amplitude == pytest.approx(surge)
    assert line.displacement == pytest.approx(surge / (2 * np.pi * f) ** 2)
    assert line.velocity == pytest.approx(surge / (2 * np.pi * f))
