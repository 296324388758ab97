"""Schedule design: the table's turns, the time budget, the dwell optimiser, the problem file, the search."""

import dataclasses
import math

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.core.orientation import DIRECTIONS, orientation_to_dcm, parse_axis, rotate_body
from casadi_sins.data.problem import GroupPlan, load_problem
from casadi_sins.studies.design.criteria import Criterion
from casadi_sins.studies.design.dwell import optimise_dwell, project
from casadi_sins.studies.design.moves import move, random_design
from casadi_sins.studies.design.problemfile import checked_text
from casadi_sins.studies.design.search import design
from casadi_sins.studies.design.space import (OUTER, GroupDesign, Limits, Turn, design_problem, equal_statics,
                                              group_plan, minimum_rests, peak_rate_deg_s,
                                              static_budget)


@pytest.fixture(scope="module")
def small_problem(kang_problem):
    """One group of three turns, 60 s rests: 270 s, a prediction in a fraction of a second."""
    group = GroupPlan("NUE", ("+Z", "+Y", "+X"), statics_s=(60.0,) * 4)
    return dataclasses.replace(kang_problem, groups=(group,), name="small")


def _attitudes(plan: GroupPlan):
    dcm = orientation_to_dcm(plan.start)
    out = [dcm]
    for axis, angle in plan.turns():
        dcm = np.round(rotate_body(dcm, axis, math.radians(angle)))
        out.append(dcm)
    return out


@pytest.mark.parametrize("axes", [1, 2, 3])
def test_random_designs_keep_the_budget_and_the_table(axes, kang_problem):
    limits = Limits(total_s=1500, max_rate_deg_s=14.0, table_axes=axes)
    rng = np.random.default_rng(axes)
    for _ in range(20):
        groups = random_design(rng, limits, 8, 1 if axes == 3 else 2)
        for _ in range(5):
            groups = move(groups, rng, limits) or groups
        statics = equal_statics(groups, limits)
        for times, low in zip(statics, minimum_rests(groups, limits)):
            assert np.all(times >= low - 1e-9)
        assert sum(t.sum() for t in statics) == pytest.approx(static_budget(groups, limits))
        problem = design_problem(kang_problem, groups, statics, limits)
        assert problem.duration <= limits.total_s + 1e-6
        turns = [s for s in problem.segments() if s.kind == "rotation"]
        assert [s.end - s.start for s in turns] == pytest.approx([limits.rotation_s(abs(s.angle_deg)) for s in turns])
        for g, times in zip(groups, statics):
            plan = group_plan(g, times, limits)
            mount = parse_axis("+" + g.mount)
            dcms = _attitudes(plan)
            for (axis, _), before, after in zip(plan.turns(), dcms[:-1], dcms[1:]):
                if axes == 1:  # every turn about the mount
                    assert abs(parse_axis(axis) @ mount) == 1.0
                if axes == 2:  # about the mount, or about the fixed north axis (which stays put)
                    assert (abs(parse_axis(axis) @ mount) == 1.0
                            or np.allclose(after.T @ DIRECTIONS[OUTER], before.T @ DIRECTIONS[OUTER]))
                    assert abs(after[:, "XYZ".index(g.mount)] @ DIRECTIONS[OUTER]) < 0.5


def test_projection_onto_the_budget():
    rng = np.random.default_rng(1)
    low = rng.uniform(10, 40, 12)
    for _ in range(20):
        y = rng.normal(60, 40, 12)
        x = project(y, low, 900.0)
        assert x.sum() == pytest.approx(900.0)
        assert np.all(x >= low - 1e-9)


def test_dwell_optimiser_finds_the_optimum_of_a_known_objective():
    """sum(w_i / t_i) under sum t_i = T has its minimum at t_i proportional to sqrt(w_i)."""
    w = np.array([1.0, 4.0, 9.0, 16.0])
    best = 400.0 * np.sqrt(w) / np.sqrt(w).sum()
    times, _ = optimise_dwell(np.full(4, 100.0), np.full(4, 20.0), lambda t: float(np.sum(w / t)), iterations=40)
    np.testing.assert_allclose(times, best, rtol=0.08)


def test_the_problem_file_reads_back_with_the_input_unit(small_problem, kang_problem, tmp_path):
    limits = Limits(total_s=500, max_rate_deg_s=14.0)
    groups = (GroupDesign("UEN", "Z", (Turn("X", 1, 180), Turn("Y", -1, 90))),)
    problem = design_problem(small_problem, groups, equal_statics(groups, limits), limits)
    path = tmp_path / "design.toml"
    path.write_text(checked_text(problem, kang_problem, "a test"))
    back = load_problem(path)
    assert back.deviations == kang_problem.deviations and back.site == kang_problem.site
    np.testing.assert_array_equal(back.truth.values, kang_problem.truth.values)
    assert 500.0 - 0.3 <= back.duration <= 500.0
    assert [g.rotations for g in back.groups] == [("+X 180", "-Y 90")]
    # each turn takes its own angle's time at the rate limit (half-sine: peak = pi/2 x mean rate)
    turns = [s.end - s.start for s in back.segments() if s.kind == "rotation"]
    assert turns == pytest.approx([limits.rotation_s(180), limits.rotation_s(90)])
    assert turns[0] == pytest.approx(2 * turns[1], abs=2e-3) and turns[1] == pytest.approx(math.pi / 2 * 90 / 14.0, abs=1e-3)
    assert peak_rate_deg_s(back) == pytest.approx(14.0, rel=1e-3)


def test_criteria_of_the_input_against_itself_are_zero(small_problem):
    for kind in ("d", "a", "worst"):
        crit = Criterion(kind, small_problem)
        score = crit.score_prediction(small_problem, crit.reference)
        assert score.value == pytest.approx(0.0, abs=1e-9)
        np.testing.assert_allclose(score.ratios, 1.0)


def test_a_design_is_no_worse_than_the_input_it_starts_from(small_problem):
    limits = Limits(total_s=small_problem.duration, max_rate_deg_s=peak_rate_deg_s(small_problem), angles=(90,))
    crit = Criterion("d", small_problem)
    best = design(small_problem, limits, crit, evaluations=4, chains=1, dwell_iterations=1)
    assert best.score.objective <= 1e-9
    assert design_problem(small_problem, best.groups, best.statics, limits).duration <= limits.total_s + 1e-6


def test_cli_design_writes_a_problem_that_analyze_takes(tmp_path, capsys):
    out = tmp_path / "d"
    assert main(["design", "problems/kang2013.toml", "--total-s", "300", "--evaluations", "2", "--out", str(out)]) == 0
    problem = load_problem(out / "design.toml")
    assert problem.duration <= 300.0 + 1e-6
    assert (out / "design.png").stat().st_size > 0 and "## Predicted sigma" in (out / "design.md").read_text()
    assert "hold for the NLP" in (out / "design.md").read_text() and "ILS design sigma" not in (out / "design.md").read_text()
    printed = capsys.readouterr().out
    turns = next(line for line in printed.splitlines() if line.startswith("turns "))
    assert all(turns.count(f"{a} deg in") <= 1 for a in (90, 180))  # each angle once, with its time
    assert main(["analyze", str(out / "design.toml"), "--out", str(tmp_path / "a")]) == 0


def test_cli_design_impossible_budget_is_one_line(tmp_path, capsys):
    out = tmp_path / "never"
    assert main(["design", "problems/kang2013.toml", "--total-s", "60", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "too short" in err
    assert not out.exists()


def test_a_schedule_leaving_an_accelerometer_axis_level_is_not_usable(small_problem):
    """Turning about the vertical axis only never shows the level axes gravity: the calibration would refuse it."""
    from casadi_sins.studies.design.search import Designer
    from casadi_sins.studies.design.space import usable

    level = (GroupDesign("NWU", "Z", (Turn("Z", 1, 90), Turn("Z", 1, 180))),)
    tumbling = (GroupDesign("NWU", "Z", (Turn("X", 1, 90), Turn("Z", 1, 90))),)
    assert not usable(level) and usable(tumbling)
    limits = Limits(total_s=400, max_rate_deg_s=14.0)
    designer = Designer(small_problem, limits, Criterion("d", small_problem))
    assert designer.evaluate(level).score.objective == np.inf


def test_cli_design_verify_reports_what_its_runs_can_say_of_the_sigma(tmp_path, capsys):
    out = tmp_path / "d"
    assert main(["design", "problems/kang2013.toml", "--total-s", "300", "--evaluations", "2", "--verify", "3",
                 "--workers", "1", "--quiet", "--out", str(out)]) == 0
    text = (out / "design.md").read_text()
    assert "at 3 runs an exact sigma gives each in 0.27-1.77 (95 %)" in text
    assert "summed joint chi-square" in text and "for 63 degrees of freedom" in text
    mc = next((out / "verify").glob("*-montecarlo.md")).read_text()
    assert "## Is the sigma honest?" in mc and mc.count("summed joint chi-square") == 2  # nlp and ils
    assert "an exact sigma gives" in capsys.readouterr().out


def test_cli_design_gives_the_ils_prediction_beside_the_nlp_when_asked(tmp_path, capsys):
    """``--solvers nlp ils``: the ILS's own predicted sigma on both schedules; on a 300 s design of one group the
    paper's method (which aligns each group) is far less precise than the NLP's prediction says."""
    out = tmp_path / "d"
    assert main(["design", "problems/kang2013.toml", "--total-s", "300", "--evaluations", "2", "--solvers", "nlp",
                 "ils", "--out", str(out)]) == 0
    text = (out / "design.md").read_text()
    assert "ILS design sigma" in text and "ILS (the paper's method) on the design" in text
    printed = capsys.readouterr().out
    nlp = float(printed.split("predicted sigma (nlp)")[1].split("geometric mean ")[1].split(",")[0])
    ils = float(printed.split("predicted sigma (ils)")[1].split("geometric mean ")[1].split(",")[0])
    assert ils > 3.0 * nlp
