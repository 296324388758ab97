"""The checks as a report shows them: each limit column holds the check's own limit, and a check's number and its
text name the same quantity."""

from __future__ import annotations

import re

from casadi_sins.calibrate import rest_check
from casadi_sins.data.rests import minimum_rest
from casadi_sins.report.tables import checks_frame


def test_shortest_rest_shows_its_limit(kang_sim):
    """The shortest rest is a least amount: its limit column is the rest accepted (0.43 s here), never the
    recording's length; it passes when the shortest static segment is at least that long."""
    rec = kang_sim.recording
    rule = minimum_rest(rec)
    check = rest_check(rec, rule)
    length = min(s.end - s.start for s in rec.static_segments)
    assert check.value == length and check.limit == rule.seconds and check.passed
    row = checks_frame([check.as_dict()]).iloc[0]
    assert row["limit"] == f">= {rule.seconds:.3g}" and row["passed"] == "yes"
    assert f"{rec.time[-1] - rec.time[0] + rec.dt:.3g}" not in row["limit"]
    short = rest_check(rec, minimum_rest(rec, stated_s=length + 1.0))
    assert not short.passed and checks_frame([short.as_dict()]).iloc[0]["passed"] == "NO"


def test_variance_ratio_checks_say_the_number_they_show(kang_nlp):
    """The residual checks' value is a variance ratio (chi-square per degree of freedom): their detail says so and
    gives that very number (not its root); the limit column is the two-sided band."""
    rows = checks_frame([c.as_dict() for c in kang_nlp.checks])
    for check in kang_nlp.checks:
        if check.name.endswith("residuals vs noise model") or check.name == "velocity steps across rotations":
            assert f"variance ratio {check.value:.3g}" in check.detail
            assert not re.search(r"\d times the noise model", check.detail)
    velocity = rows[rows["name"] == "velocity residuals vs noise model"].iloc[0]
    assert re.fullmatch(r"0\.\d+ to 1\.\d+", velocity["limit"])
