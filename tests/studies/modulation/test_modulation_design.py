"""``design-scheme``: the proxies against the full propagation, the search against brute force, the files,
and bad input as one line and exit 2."""

import itertools
import json
from pathlib import Path

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.core import units
from casadi_sins.core.errors import InputError
from casadi_sins.studies.modulation.covariance import propagate
from casadi_sins.studies.modulation.design import Request, check_request, error_root, proxy, responses, step_tables
from casadi_sins.studies.modulation.designer import Candidate, StepPropagator, criterion_value, design, to_scheme
from casadi_sins.studies.modulation.schemes import closure_error, load_scheme

SHEETS = Path(__file__).resolve().parents[3] / "problems"
IMPROVED = "z+ y- z+ y- y- z+ y- z+ y+ z- y+ z- z- y+ z- y+"
COMMON = "z+ y+ z- y- y+ z+ y- z- z- y- z+ y+ y- z- y+ z+"


def indices(notation):
    table = {"z+": 0, "z-": 1, "y+": 2, "y-": 3}
    return tuple(table[x] for x in notation.split())


def yu_request(hours=24.0, criterion="position"):
    return Request(16, 2, 20 * units.DEG, 45.0, hours, criterion)


def test_step_propagator_is_the_covariance_propagation(guan_sheet, guan_site):
    """The candidates' fast propagation (one product per period) equals covariance.propagate, noise included."""
    req = Request(4, 2, 20 * units.DEG, 45.0, 0.5)
    cand = Candidate(("y",), indices("z+ y- z+ y-"), 22.5, 0.0)
    fast = StepPropagator(req, guan_sheet, guan_site, ("y",)).propagate(cand)
    full = propagate(to_scheme(cand, req, "x"), guan_site, 0.5, guan_sheet.gyro_arw, guan_sheet.accel_vrw)
    n = len(fast.time)
    assert n >= len(full.time) - 1
    assert np.allclose(fast.time, full.time[:n])
    assert np.allclose(fast.sensitivity, full.sensitivity[:n], rtol=1e-9, atol=1e-12 * np.abs(full.sensitivity).max())
    for name in ("gyro noise", "accel noise"):
        assert np.allclose(fast.noise[name], full.noise[name][:n], rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("notation", [IMPROVED, COMMON])
def test_the_proxy_predicts_the_propagated_criterion(notation, yu_ruan_sheet, yu_ruan_site):
    """The period-mean tilt and the residual drift through the static dynamics give the 24 h maximum of the
    shipped schemes to 5 %."""
    req = yu_request()
    tables = step_tables(req, yu_ruan_site, ("y",), error_root(yu_ruan_sheet))
    predicted = proxy(np.array([indices(notation)]), tables, req, yu_ruan_site, responses(req, yu_ruan_site))[0]
    prop = StepPropagator(req, yu_ruan_sheet, yu_ruan_site, ("y",)).propagate(Candidate(("y",), indices(notation), 0, 0))
    assert predicted == pytest.approx(criterion_value(prop, yu_ruan_sheet, "position"), rel=0.05)


def test_a_sequence_that_does_not_close_has_no_proxy(yu_ruan_sheet, yu_ruan_site):
    req = yu_request()
    tables = step_tables(req, yu_ruan_site, ("y",), error_root(yu_ruan_sheet))
    seq = np.array([indices(IMPROVED)])
    seq[0, 0] = 2  # one z turn made a y turn: z and y each turn an odd number of times
    assert np.isinf(proxy(seq, tables, req, yu_ruan_site, responses(req, yu_ruan_site))[0])


def test_single_axis_search_finds_the_best_of_every_sequence(yu_ruan_sheet, yu_ruan_site):
    """A space small enough to enumerate: the design is at least as good as every closed single-axis
    sequence of 6 positions (start phase 0), each propagated in full."""
    req = Request(6, 1, 20 * units.DEG, 45.0, 2.0)
    result = design(req, yu_ruan_sheet, yu_ruan_site, confirm=20)
    prop = StepPropagator(req, yu_ruan_sheet, yu_ruan_site, ())
    every = [criterion_value(prop.propagate(Candidate((), seq, 0.0, 0.0)), yu_ruan_sheet, "position")
             for seq in itertools.product(range(2), repeat=6)]
    assert result.best.value <= min(every) * (1 + 1e-9)
    assert closure_error(result.scheme) < 1e-9


def test_the_design_is_deterministic_and_its_figure_is_the_best_confirmed(yu_ruan_sheet, yu_ruan_site):
    req = Request(4, 2, 20 * units.DEG, 45.0, 1.0)
    a = design(req, yu_ruan_sheet, yu_ruan_site, samples=200, starts=2, confirm=6)
    b = design(req, yu_ruan_sheet, yu_ruan_site, samples=200, starts=2, confirm=6)
    assert a.best.notation() == b.best.notation() and a.best.dwell0 == b.best.dwell0
    assert a.best.value == min(c.value for c in a.confirmed)


@pytest.mark.parametrize("change, words", [
    ({"positions": 15}, "even"),
    ({"positions": 0}, "--positions"),
    ({"axes": 3}, "--axes"),
    ({"stop": -1.0}, "--stop-s"),
    ({"hours": 0.01}, "shorter than one period"),
    ({"criterion": "best"}, "--criterion"),
])
def test_impossible_requests_are_refused(change, words, yu_ruan_sheet, yu_ruan_site):
    args = dict(positions=16, axes=2, rate=20 * units.DEG, stop=45.0, hours=24.0, criterion="position")
    args.update(change)
    with pytest.raises(InputError, match=words):
        check_request(Request(**args), yu_ruan_sheet, yu_ruan_site)


def run(capsys, *args):
    code = main(["design-scheme", *map(str, args)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_cli_writes_a_scheme_modulate_takes(tmp_path, capsys):
    out = tmp_path / "d"
    code, stdout, err = run(capsys, "--errors", SHEETS / "yu-ruan2014-sim.toml", "--positions", 4, "--rate-deg-s",
                            20, "--stop-s", 45, "--hours", 1, "--latitude", 45.77, "--samples", 200, "--out", out)
    assert code == 0, err
    assert "design-scheme:" in err  # progress
    doc = json.loads((out / "design.json").read_text())
    scheme = load_scheme(out / "scheme.toml")
    assert len(scheme.steps) == 4 and closure_error(scheme) < 1e-9
    assert scheme.initial_dwell == doc["design"]["first_turn_after_s"]
    code, stdout, err = main(["modulate", "--errors", str(SHEETS / "yu-ruan2014-sim.toml"), "--scheme",
                              str(out / "scheme.toml"), "--hours", "1", "--latitude", "45.77", "--out",
                              str(tmp_path / "m"), "--no-plots"]), None, None
    assert code == 0
    mod = json.loads((tmp_path / "m" / "modulation.json").read_text())
    assert mod["schemes"][scheme.name]["max_horizontal_position_error_m"] == pytest.approx(
        doc["comparison"][scheme.name]["max_horizontal_position_error_m"], rel=1e-6)
    assert "| designed-4 |" in (out / "design.md").read_text()


def test_cli_a_sheet_without_sensor_errors_is_one_line(tmp_path, capsys):
    sheet = tmp_path / "s.toml"
    sheet.write_text('format = "casadi-sins-errors/1"\nsigma_level = 1\n[initial]\nlevel_arcsec = 10.0\n')
    code, _, err = run(capsys, "--errors", sheet, "--positions", 4, "--rate-deg-s", 20, "--stop-s", 45, "--hours",
                       1, "--latitude", 45, "--out", tmp_path / "d")
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and "nothing for a rotation scheme to modulate" in lines[0]
    assert not (tmp_path / "d" / "scheme.toml").exists()


def test_cli_odd_positions_is_one_line(tmp_path, capsys):
    code, _, err = run(capsys, "--errors", "yu-ruan2014-sim", "--positions", 5, "--rate-deg-s", 20, "--stop-s", 45,
                       "--hours", 1, "--latitude", 45, "--out", tmp_path / "d")
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and "cannot return to the start attitude" in lines[0]
