"""The simulator's session by hand (sim.hand): its increments carry each rest into the next, its rests are rests."""

import dataclasses

import numpy as np
import pytest

from casadi_sins.core.errors import InputError
from casadi_sins.core.rotations import rotation_matrices, rotation_vector
from casadi_sins.data.problem import load_problem
from casadi_sins.model.output import compensate
from casadi_sins.sim import simulate
from casadi_sins.sim.hand import attitude_in_cone, plan_hand


def carried(rec, truth, first: int, stop: int) -> np.ndarray:
    """The body rotation over samples ``[first, stop)`` from the compensated increments, sample by sample with the
    two-sample coning correction (the strapdown step's: the increments are integrals of the rate)."""
    dtheta, _ = compensate(rec.gyro[first:stop], rec.accel[first:stop], truth.core, rec.dt)
    previous = np.vstack([np.zeros(3), dtheta[:-1]])
    out = np.eye(3)
    for step in rotation_matrices(dtheta + np.cross(previous, dtheta) / 12.0):
        out = out @ step
    return out


def test_the_increments_carry_each_rest_into_the_next(hand_sim_exact):
    """Without noise, the true attitude of rest k, the integrated gyro increments (inertial) and the Earth's turn
    meanwhile give rest k+1's attitude, to the coning of a sample-by-sample integration."""
    rec, truth = hand_sim_exact.recording, hand_sim_exact.truth
    statics = rec.static_segments
    for k in range(len(statics) - 1):
        a, b = rec.segment_samples(statics[k]), rec.segment_samples(statics[k + 1])
        earth = rotation_matrices(-rec.site.earth_rate * (b.start - a.stop) * rec.dt)
        predicted = earth @ hand_sim_exact.static_attitudes[k] @ carried(rec, truth, a.stop, b.start)
        miss = rotation_vector(predicted.T @ hand_sim_exact.static_attitudes[k + 1])
        assert np.degrees(np.linalg.norm(miss)) < 2e-3


def test_rests_hold_gravity_and_moves_reach_their_peak_rates(hand_sim_exact, hand_problem):
    rec, truth = hand_sim_exact.recording, hand_sim_exact.truth
    rates, force = compensate(rec.gyro, rec.accel, truth.core, rec.dt)
    for seg in rec.static_segments:  # means over each rest: the counts are integers (quantisation, one count)
        sl = rec.segment_samples(seg)
        assert np.linalg.norm(force[sl].mean(axis=0)) / rec.dt == pytest.approx(rec.site.g, rel=2e-6)
        assert np.degrees(np.linalg.norm(rates[sl].mean(axis=0))) / rec.dt < 0.005  # deg/s: the Earth rate
    peak = np.degrees(np.max(np.linalg.norm(rates, axis=1))) / rec.dt
    assert hand_problem.hand.peak_rate_deg_s[0] < peak <= 1.05 * hand_problem.hand.peak_rate_deg_s[1]


def test_tremor_moves_the_rests_about_their_attitude(hand_sim, hand_problem):
    """With tremor the rests rate at tenths of a degree per second, but their mean rate (once the hand has settled)
    stays a tiny part of it: the unit trembles about its attitude."""
    rec, truth = hand_sim.recording, hand_sim.truth
    rates, _ = compensate(rec.gyro, rec.accel, truth.core, rec.dt)
    seg = rec.static_segments[3]
    sl = rec.sample_range(seg.start + 1.5, seg.end)
    spread = np.degrees(np.std(rates[sl], axis=0)) / rec.dt
    assert np.all(spread > 0.2)  # noise and tremor, deg/s
    mean = np.degrees(np.abs(rates[sl].mean(axis=0))) / rec.dt
    assert np.all(mean < 0.05)


def test_a_cone_keeps_gravity_near_the_first_rests():
    rng = np.random.default_rng(0)
    first = rotation_matrices(np.array([0.3, -1.2, 0.7]))
    for _ in range(50):
        other = attitude_in_cone(rng, first, 25.0)
        cos = (first.T @ [0, 0, 1]) @ (other.T @ [0, 0, 1])
        assert np.degrees(np.arccos(np.clip(cos, -1, 1))) <= 25.0 + 1e-9


def test_the_schedule_is_the_layout_seeds_and_the_motion_the_simulation_seeds(hand_problem):
    assert hand_problem.segments() == hand_problem.segments()
    a, b = (plan_hand(hand_problem, np.random.default_rng(s)) for s in (1, 2))
    assert not np.allclose(a.rest_attitudes[1], b.rest_attitudes[1])
    assert all(s.is_free for s in hand_problem.segments())


def test_a_problem_has_groups_or_a_hand_session_and_only_known_keys(tmp_path):
    base = (load_problem.__globals__["default_problem_path"]()).read_text()
    both = tmp_path / "both.toml"
    both.write_text(base + "\n[hand]\nrests = 12\n")
    with pytest.raises(InputError, match=r"\[\[groups\]\] .* or \[hand\]"):
        load_problem(both)
    hand = (load_problem.__globals__["default_problem_path"]().parent / "hand-mems.toml").read_text()
    unknown = tmp_path / "unknown.toml"
    unknown.write_text(hand.replace("[hand]", "[hand]\nwobble = 3"))
    with pytest.raises(InputError, match=r"\[hand\] unknown key\(s\) wobble"):
        load_problem(unknown)
