"""``design --criterion navigation --scheme``: a calibration's covariance as the residual errors of a
rotation-modulated INS, checked against the static error budget and the modulation analysis."""

import dataclasses

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.data.problem import GroupPlan, load_problem
from casadi_sins.model.registry import GROUPS, NAMES
from casadi_sins.studies.budget import problem_budget
from casadi_sins.studies.design.criteria import Criterion
from casadi_sins.studies.design.modulated import ModulatedNavigation
from casadi_sins.studies.modulation.analysis import analyse
from casadi_sins.studies.modulation.calibrated import parameter_sources
from casadi_sins.studies.modulation.schemes import load_scheme
from casadi_sins.studies.prediction import predict_problem


@pytest.fixture(scope="module")
def small_problem(kang_problem):
    group = GroupPlan("NUE", ("+Z", "+Y", "+X"), statics_s=(60.0,) * 4)
    return dataclasses.replace(kang_problem, groups=(group,), name="small")


@pytest.fixture(scope="module")
def prediction(small_problem):
    pred = predict_problem(small_problem, "21")
    return pred.nominal.values[:21], np.asarray(pred.nominal.covariance)[:21, :21]


def _group_only(cov, key):
    idx = [NAMES.index(n) for n in GROUPS[key].names]
    out = np.zeros_like(cov)
    out[np.ix_(idx, idx)] = cov[np.ix_(idx, idx)]
    return out


@pytest.mark.parametrize("key", ["gyro_bias", "gyro_scale", "gyro_misalign", "accel_bias"])
def test_strapdown_scheme_matches_the_static_budget_group_by_group(small_problem, prediction, key):
    """Two error models written apart (the budget's and the modulation's) give the same largest position error
    for each group's residual alone, noise-free, aligned at the start (the budget's alignment noise is noise)."""
    quiet = small_problem.with_changes(accel_noise_ug=0.0, gyro_noise_deg_h=0.0)
    values, cov = prediction
    part = _group_only(cov, key)
    modulated = ModulatedNavigation(quiet, load_scheme("strapdown"), 6.0)(values, part)
    budget = problem_budget(quiet, values, part, orientation="ENU", hours=6.0)
    static = float(np.hypot(*np.asarray(budget.contributions[next(k for k in budget.contributions
                                                                  if GROUPS[key].label in k)]).T).max())
    assert modulated > 0.0
    assert modulated == pytest.approx(static, rel=0.03)


def test_modulated_value_is_what_modulate_reports(small_problem, prediction):
    values, cov = prediction
    scheme = load_scheme("single-axis-reciprocating")
    nav = ModulatedNavigation(small_problem, scheme, 4.0)
    sources = parameter_sources(NAMES, values, cov, nav.gyro_arw, nav.accel_vrw)
    doc, _ = analyse([scheme], sources, nav.site, 4.0, aligned=True)
    assert nav(values, cov) == pytest.approx(doc["schemes"][scheme.name]["max_horizontal_position_error_m"],
                                             rel=1e-6)


def test_modulated_error_grows_with_the_calibration_covariance_and_keeps_the_noise_floor(small_problem, prediction):
    values, cov = prediction
    nav = ModulatedNavigation(small_problem, load_scheme("dual-axis-16"), 8.0)
    floor, one, four = nav(values, 0 * cov), nav(values, cov), nav(values, 4 * cov)
    assert 0.0 < floor < one < four
    # the calibration part scales with sigma: sqrt(four^2 - floor^2) = 2 sqrt(one^2 - floor^2) up to the max's time
    assert np.sqrt(four**2 - floor**2) == pytest.approx(2 * np.sqrt(one**2 - floor**2), rel=0.05)


def test_scheme_criterion_of_the_input_against_itself_is_zero(small_problem, prediction):
    scheme = load_scheme("dual-axis-16")
    crit = Criterion("navigation", small_problem, hours=8.0, scheme=scheme)
    score = crit.score_prediction(small_problem, crit.reference)
    assert score.value == pytest.approx(0.0, abs=1e-12)
    assert crit.ref_navigation == pytest.approx(ModulatedNavigation(small_problem, scheme, 8.0)(*prediction))
    with pytest.raises(ValueError, match="navigation"):
        Criterion("d", small_problem, scheme=load_scheme("dual-axis-16"))


def test_cli_design_with_a_scheme_writes_its_navigation(tmp_path):
    out = tmp_path / "d"
    assert main(["design", "problems/kang2013.toml", "--total-s", "300", "--evaluations", "2", "--criterion",
                 "navigation", "--scheme", "dual-axis-16", "--hours", "4", "--quiet", "--out", str(out)]) == 0
    text = (out / "design.md").read_text()
    reference = Criterion("navigation", load_problem("problems/kang2013.toml"), hours=4.0,
                          scheme=load_scheme("dual-axis-16")).ref_navigation
    assert "under rotation scheme dual-axis-16: design " in text and f"input {reference:.4g} m" in text


@pytest.mark.parametrize("args, message", [
    (["--scheme", "dual-axis-16"], "--criterion navigation"),
    (["--criterion", "navigation", "--scheme", "no-such-scheme"], "no-such-scheme"),
    (["--criterion", "navigation", "--hours", "1e12"], "beyond 1000 h"),
    (["--criterion", "navigation", "--hours", "nan"], "--hours: 'nan' is not a finite decimal number"),
])
def test_cli_design_bad_scheme_is_one_line(tmp_path, capsys, args, message):
    out = tmp_path / "never"
    assert main(["design", "problems/kang2013.toml", "--total-s", "300", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err
    assert not out.exists()
