"""Slow handling between groups in the simulator (issue 16): a hand tumble with minimum-jerk legs."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from casadi_sins.core.errors import InputError
from casadi_sins.core.rotations import rotation_vector
from casadi_sins.data.problem import load_problem
from casadi_sins.sim.motion import HANDLING_PEAK_DEG_S, MotionPiece, plan_motion

PROBLEMS = Path(__file__).resolve().parents[2] / "problems"


@pytest.mark.parametrize("seed", [1, 3])
def test_minimum_jerk_handling_tumbles_to_the_next_start_within_the_gap_at_about_15_deg_s(seed):
    problem = load_problem(PROBLEMS / "segmentation-handling.toml")
    assert problem.timing.handling == "minimum-jerk" and problem.timing.gap_s == 60.0
    pieces, starts, _, _ = plan_motion(problem, np.random.default_rng(seed))
    segments = problem.segments()
    end_1 = max(s.end for s in segments if s.group == 1)
    start_2 = min(s.start for s in segments if s.group == 2)
    handling = [p for p in pieces if end_1 <= p.t0 and p.t1 <= start_2]
    legs = [p for p in handling if p.axis is not None]
    assert len(legs) == 4 and handling[0].t0 == end_1 and handling[-1].t1 == start_2
    assert all(a.t1 == pytest.approx(b.t0) for a, b in zip(handling[:-1], handling[1:]))  # no gap, no overlap
    peaks = []
    for leg in legs:
        t = np.linspace(leg.t0, leg.t1, 2001)
        rate = np.degrees(leg.rate_at(t))
        assert leg.profile == "minimum-jerk"
        peaks.append(rate.max())
        assert rate[0] == 0.0 and rate[-1] == pytest.approx(0.0, abs=1e-12)
        # the rate starts like t^2: a tenth of the leg in, it is 30 x 0.01 x 0.81 of the mean rate
        assert rate[200] == pytest.approx(30 * 0.1**2 * 0.9**2 * np.degrees(leg.angle) / (leg.t1 - leg.t0), rel=1e-9)
        assert np.degrees(leg.angle_at(np.array(leg.t1))) == pytest.approx(np.degrees(leg.angle))
    # every leg peaks at 15 deg/s, pausing at the waypoints; faster (all alike) only when the legs need the whole gap
    assert np.ptp(peaks) < 1e-3 * peaks[0] and HANDLING_PEAK_DEG_S * (1 - 1e-3) < peaks[0] < 2 * HANDLING_PEAK_DEG_S
    moving = sum(leg.t1 - leg.t0 for leg in legs)
    assert moving < 60.0 - 1e-9 if peaks[0] < HANDLING_PEAK_DEG_S * (1 + 1e-3) else moving == pytest.approx(60.0)
    last = legs[-1].end_attitude
    assert np.degrees(np.linalg.norm(rotation_vector(last.T @ starts[2]))) < 1e-9  # ends at group 2's start


def test_the_default_handling_is_one_turn_and_draws_nothing():
    problem = load_problem(PROBLEMS / "segmentation-2groups.toml")
    assert problem.timing.handling == "turn"
    pieces, *_ = plan_motion(problem, np.random.default_rng(3))
    handling = [p for p in pieces if p.profile == "half-sine" and p.t1 - p.t0 == problem.timing.gap_s]
    assert len(handling) == 1
    # the same draws as without the option: the next random number after planning is unchanged
    a, b = np.random.default_rng(3), np.random.default_rng(3)
    plan_motion(problem, a)
    plan_motion(dataclasses.replace(problem, timing=dataclasses.replace(problem.timing, handling="turn")), b)
    assert a.random() == b.random()


def test_an_unknown_handling_is_refused_naming_the_key(tmp_path):
    text = (PROBLEMS / "segmentation-handling.toml").read_text().replace('"minimum-jerk"', '"teleport"')
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=r"\[timing\] handling must be one of turn, minimum-jerk"):
        load_problem(path)


def test_minimum_jerk_piece_integrates_its_rate():
    piece = MotionPiece(2.0, 12.0, np.eye(3), np.array([0.0, 0.0, 1.0]), 1.3, "minimum-jerk")
    t = np.linspace(2.0, 12.0, 100001)
    integral = np.concatenate([[0.0], np.cumsum((piece.rate_at(t[1:]) + piece.rate_at(t[:-1])) / 2 * np.diff(t))])
    assert np.abs(integral - piece.angle_at(t)).max() < 1e-8
