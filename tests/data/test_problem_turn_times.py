"""Problem files with a duration per turn (``rotations_s``): read, simulated and calibrated as stated."""

import dataclasses

import numpy as np
import pytest

from casadi_sins.calibrate import calibrate_nlp
from casadi_sins.core.errors import InputError
from casadi_sins.data.problem import GroupPlan, load_problem
from casadi_sins.model.parameters import natural_errors
from casadi_sins.sim import simulate
from casadi_sins.studies.design.problemfile import kept_tables
from casadi_sins.studies.prediction import predict_problem

TIMING = """
[timing]
static_s = 45
rotation_s = 10
"""
SCHEDULE = """
[[groups]]
start = "NWU"
rotations = ["+X 90", "-Y 180", "+Y 90", "-Z 90", "+X 180", "+Z 180"]
statics_s = [60, 45, 45, 45, 45, 45, 45]
rotations_s = [10, 20, 10, 10, 20, 20]
"""


def _problem(tmp_path, schedule: str = SCHEDULE):
    text = kept_tables(load_problem().source.read_text(encoding="utf-8"))  # the paper's unit, site and truth
    text = 'format = "casadi-sins-problem/1"\nname = "turns"\n' + text + TIMING + schedule
    path = tmp_path / "p.toml"
    path.write_text(text, encoding="utf-8")
    return load_problem(path)


def test_each_turn_lasts_its_stated_time_in_the_schedule_and_the_recording(tmp_path):
    problem = _problem(tmp_path)
    turns = [s.end - s.start for s in problem.segments() if s.kind == "rotation"]
    assert turns == [10, 20, 10, 10, 20, 20]
    assert problem.duration == pytest.approx(60 + 6 * 45 + 90)
    sim = simulate(problem, seed=2, noise=False)
    assert [s.end - s.start for s in sim.recording.segments if s.kind == "rotation"] == pytest.approx(turns)


def test_a_schedule_of_mixed_turn_times_calibrates_to_its_truth_without_noise(tmp_path):
    problem = _problem(tmp_path)
    sim = simulate(problem, seed=2, noise=False)
    result = calibrate_nlp(sim.recording)
    errors = natural_errors(result.parameters, sim.truth)
    # noise-free: every error is a small fraction of the sigma the problem's noise would give
    assert np.max(np.abs(errors / predict_problem(problem).sigma_natural)) < 0.02


def test_without_rotations_s_every_turn_takes_the_timing_rotation_s(kang_problem):
    turns = {s.end - s.start for s in kang_problem.segments() if s.kind == "rotation"}
    assert turns == {kang_problem.timing.rotation_s}
    same = dataclasses.replace(kang_problem, groups=tuple(
        dataclasses.replace(g, rotations_s=(kang_problem.timing.rotation_s,) * len(g.rotations))
        for g in kang_problem.groups))
    assert same.segments() == kang_problem.segments()


@pytest.mark.parametrize("line, message", [
    ("rotations_s = [20, 20]", "rotations_s must list 6 durations"),
    ("rotations_s = [10, 20, 10, 10, 20, 0]", "rotations_s must be positive"),
    ('rotations_s = [10, 20, 10, 10, 20, "x"]', "must be a finite number"),
    ("rotations_s = [10, 20, 10, 10, 20, 1e300]", "samples: more than 1e"),
])
def test_bad_rotations_s_names_the_group(tmp_path, line, message):
    with pytest.raises(InputError, match=message) as info:
        _problem(tmp_path, SCHEDULE.replace("rotations_s = [10, 20, 10, 10, 20, 20]", line))
    assert "[[groups]] 1" in str(info.value) or "groups 1" in str(info.value) or "schedule lasts" in str(info.value)


def test_a_plan_whose_turn_times_do_not_match_its_turns_is_refused(kang_problem):
    plan = GroupPlan("NUE", ("+Z", "+Y"), rotations_s=(10.0,))
    with pytest.raises(ValueError):
        dataclasses.replace(kang_problem, groups=(plan,)).segments()
