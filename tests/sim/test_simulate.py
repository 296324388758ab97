"""The simulator: schedule, exact kinematics, noise, quantisation."""

import numpy as np
import pytest

from casadi_sins.core import earth, orientation, rotations
from casadi_sins.core.units import DEG, UG
from casadi_sins.model.output import compensate
from casadi_sins.nav.navigation import navigate
from casadi_sins.sim import simulate
from casadi_sins.sim.motion import MotionPiece
from casadi_sins.sim.simulate import quantize, true_increments


def test_paper_schedule_matches_table1(kang_problem):
    segs = kang_problem.segments()
    assert kang_problem.duration == pytest.approx(1290.0)
    statics = [s.orientation for s in segs if s.is_static]
    assert statics == ["NUE", "USE", "SDE", "DNE", "NED", "UEN", "SEU", "DES", "NUE", "NED", "NDW", "NWU"]
    assert [s.axis for s in segs if not s.is_static] == ["+Z"] * 3 + ["+Y"] * 3 + ["+X"] * 3
    assert all(s.end - s.start == pytest.approx(100.0 if s.is_static else 10.0) for s in segs)
    # Table 2 truth, gyro scale converted from deg/pulse
    assert kang_problem.truth["gyro_scale_x"] == pytest.approx(5.644819e-6 * DEG, rel=1e-15)


def test_rotation_increments_integrate_to_the_turned_angle():
    """Sum of exact increments over a rotation = turned angle + the integral of Earth rate."""
    c0 = orientation.orientation_to_dcm("NUE")
    axis = np.array([0.004, 0.004, 1.0]) / np.linalg.norm([0.004, 0.004, 1.0])
    piece = MotionPiece(0.0, 10.0, c0, axis, np.pi / 2 * 1.003)
    w_ie = earth.earth_rate_enu(np.radians(37.5))
    dtheta, dv = true_increments([piece], 1000, 0.01, w_ie, 9.8)
    # the Earth-rate integral by a much finer independent rule (midpoints, 200 000 points)
    t = (np.arange(200000) + 0.5) * 10.0 / 200000
    earth_turn = np.einsum("tji,j->i", piece.attitude_at(t), w_ie) * 10.0 / 200000
    np.testing.assert_allclose(dtheta.sum(axis=0), axis * np.pi / 2 * 1.003 + earth_turn, rtol=0, atol=1e-14)
    gravity = np.einsum("tji,j->i", piece.attitude_at(t), [0, 0, 9.8]) * 10.0 / 200000
    np.testing.assert_allclose(dv.sum(axis=0), gravity, rtol=0, atol=1e-9)


def test_noise_free_navigation_with_truth_is_far_below_the_noise(kang_sim_noiseless):
    """Kinematics check: the simulator's increments, compensated with the truth and navigated from the true
    start attitude, leave < 1e-6 m/s over each 430 s group (the noise random walk is ~1e-3 m/s)."""
    sim = kang_sim_noiseless
    for nav in navigate(sim.recording, sim.truth.values, sim.start_attitudes):
        assert np.abs(nav.velocity).max() < 1e-6


def test_sensor_noise_has_the_stated_level(kang_sim):
    rec = kang_sim.recording
    dtheta, dv = compensate(rec.gyro, rec.accel, kang_sim.truth.values, rec.dt)
    sl = rec.segment_samples(rec.segments[0])
    accel_noise = dv[sl].std(axis=0) / rec.dt / UG
    np.testing.assert_allclose(accel_noise, 50.0, rtol=0.03)  # 10 000 samples: 0.7 % standard error
    gyro_noise = dtheta[sl].std(axis=0) / rec.dt / (DEG / 3600)
    np.testing.assert_allclose(gyro_noise, 0.01, rtol=0.03)


def test_start_attitudes_are_off_nominal_by_the_stated_angle(kang_sim, kang_problem):
    for group, plan in enumerate(kang_problem.groups, start=1):
        off = rotations.rotation_vector(kang_sim.start_attitudes[group] @ orientation.orientation_to_dcm(plan.start).T)
        np.testing.assert_allclose(np.abs(off), 0.4 * DEG, rtol=1e-3)
    assert all(abs(f - 1) <= 0.004 for f in kang_sim.rate_factors)


def test_quantized_pulses_are_integers_and_keep_the_sum():
    rng = np.random.default_rng(0)
    pulses = rng.uniform(0, 7, (1000, 3))
    q = quantize(pulses)
    assert np.all(q == np.round(q))
    assert np.abs(np.cumsum(q, axis=0) - np.cumsum(pulses, axis=0)).max() <= 0.5 + 1e-9


def test_seed_reproduces_and_differs(short_problem):
    a, b, c = simulate(short_problem, seed=4), simulate(short_problem, seed=4), simulate(short_problem, seed=5)
    np.testing.assert_array_equal(a.recording.accel, b.recording.accel)
    assert not np.array_equal(a.recording.accel, c.recording.accel)


def test_handling_between_groups_is_simulated_and_ignored(short_problem):
    import dataclasses

    gap = dataclasses.replace(short_problem, timing=dataclasses.replace(short_problem.timing, gap_s=5.0))
    sim = simulate(gap, seed=0, noise=False)
    rec = sim.recording
    g2 = rec.group_segments(2)[0]
    assert g2.start == pytest.approx(rec.group_segments(1)[-1].end + 5.0)
    handling = rec.sample_range(rec.group_segments(1)[-1].end, g2.start)
    assert np.abs(rec.gyro[handling]).max() > 100 * np.abs(rec.gyro[rec.segment_samples(g2)]).max()
    for nav in navigate(rec, sim.truth.values, sim.start_attitudes):
        assert np.abs(nav.velocity).max() < 1e-6
