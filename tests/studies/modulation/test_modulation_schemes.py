"""Scheme files: parsing, the exact attitude of the turns, closure, shipped names and bad input."""

import math
from pathlib import Path

import numpy as np
import pytest

from casadi_sins.core import rotations
from casadi_sins.core.errors import InputError
from casadi_sins.studies.modulation.schemes import (MAX_PIECES, closure_error, load_scheme, parse_scheme,
                                                    period_pieces, scheme_pieces)

SCHEMES = Path(__file__).resolve().parents[3] / "problems" / "schemes"


def step(axis="z", angle=180.0, rate=10.0, dwell=30.0):
    raw = {"axis": axis, "angle_deg": angle, "rate_deg_s": rate}
    if dwell is not None:
        raw["dwell_s"] = dwell
    return raw


def test_twelve_schemes_are_shipped():
    assert len(list(SCHEMES.glob("*.toml"))) == 12


@pytest.mark.parametrize("path", sorted(SCHEMES.glob("*.toml")), ids=lambda p: p.stem)
def test_every_shipped_scheme_loads_and_returns_to_its_start(path):
    scheme = load_scheme(path)
    assert closure_error(scheme) < 1e-9
    assert scheme.name == path.stem
    by_name = load_scheme(path.stem)
    assert by_name.source == f"{path.stem} (shipped)" and len(by_name.steps) == len(scheme.steps)


def test_turn_is_exact_rotation_about_the_body_axis():
    scheme = parse_scheme({"step": [step("z", 90.0, 10.0, 5.0), step("y", -180.0, 20.0, 5.0)]})
    turn_z, dwell, turn_y, _ = period_pieces(scheme, np.eye(3))
    assert turn_z.duration == pytest.approx(9.0) and turn_y.duration == pytest.approx(9.0)
    np.testing.assert_allclose(turn_z.end_attitude, rotations.rotation_matrix([0, 0, 1], math.pi / 2), atol=1e-15)
    # body y after a 90 deg turn about z points west: turning about body y is turning about west
    expected = rotations.rotation_matrix([-1, 0, 0], -math.pi) @ turn_z.end_attitude
    np.testing.assert_allclose(turn_y.end_attitude, expected, atol=1e-14)
    np.testing.assert_allclose(turn_y.turn_rate(turn_y.t0 + 4.5), [0, -math.radians(20.0), 0])


def test_base_axis_turn_equals_the_same_turn_about_the_body_axis_it_is_at_that_moment():
    a = parse_scheme({"start": "NWU", "step": [step("U", 90.0), step("E", 180.0)]})
    # start NWU: x north, y west, z up; after +90 deg about up: x west, y south, so east is -x
    b = parse_scheme({"start": "NWU", "step": [step("z", 90.0), step("x", -180.0)]})
    end_a = period_pieces(a, a.start)[-1].end_attitude
    end_b = period_pieces(b, b.start)[-1].end_attitude
    np.testing.assert_allclose(end_a, end_b, atol=1e-14)


def test_pieces_repeat_the_period_and_cut_the_last():
    scheme = parse_scheme({"step": [step("z", 180.0, 20.0, 45.0), step("z", -180.0, 20.0, 45.0)]})
    pieces = scheme_pieces(scheme, 250.0)
    assert sum(p.duration for p in pieces) == pytest.approx(250.0)
    assert [p.axis is None for p in pieces][:5] == [False, True, False, True, False]
    np.testing.assert_array_equal(pieces[4].attitude, pieces[0].attitude)  # the same matrix, no round-off


def test_strapdown_is_one_dwell():
    pieces = scheme_pieces(load_scheme("strapdown"), 3600.0)
    assert len(pieces) == 1 and pieces[0].axis is None and pieces[0].duration == 3600.0


@pytest.mark.parametrize("raw,message", [
    (step(axis="w"), "unknown axis"),
    (step(axis="+z"), "unknown axis"),
    (step(rate=0.0), "rate_deg_s must be > 0"),
    (step(rate=-5.0), "rate_deg_s must be > 0"),
    (step(dwell=0.0), "dwell_s must be > 0"),
    (step(dwell=-1.0), "dwell_s must be > 0"),
    (step(angle=float("nan")), "not finite"),
    (step(rate=float("inf")), "not finite"),
    (step(angle=1e9), "ten revolutions"),
    ({"axis": "z", "angle_deg": 90.0}, "missing rate_deg_s"),
    ({**step(), "speed": 3}, "unknown key"),
    (step(angle=0.0, dwell=None), "neither turns nor dwells"),
])
def test_bad_steps_are_refused_in_one_line(raw, message):
    with pytest.raises(InputError, match=message) as exc:
        parse_scheme({"step": [raw]}, "my.toml")
    assert str(exc.value).startswith("my.toml: step 1: ") and "\n" not in str(exc.value)


def test_a_bad_step_of_a_file_is_named_by_its_line(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text('format = "casadi-sins-scheme/1"\nname = "mine"\n\n[[step]]\naxis = "z"\nangle_deg = 90.0\n'
                    'rate_deg_s = 10.0\n\n[[step]]\naxis = "q"\nangle_deg = 90.0\nrate_deg_s = 10.0\n')
    with pytest.raises(InputError, match="step 2: unknown axis") as exc:
        load_scheme(path)
    assert exc.value.line == 9 and exc.value.path == path


@pytest.mark.parametrize("text,message", [
    ('name = "x"\n', "format must be 'casadi-sins-scheme/1'"),
    ('format = "casadi-sins-problem/1"\n', "format must be"),
    ('format = "casadi-sins-scheme/1"\nstart = "ENX"\n', "start: orientation"),
    ('format = "casadi-sins-scheme/1"\nstart = "ENU"\nextra = 1\n', "unknown key"),
    ('format = "casadi-sins-scheme/1"\nstep = 3\n', "array of tables"),
    ("format = [\n", "not valid TOML"),
])
def test_bad_scheme_files(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        load_scheme(path)


def test_unknown_names_list_the_shipped_schemes(tmp_path):
    with pytest.raises(InputError, match="no such scheme file or shipped scheme .*dual-axis-16"):
        load_scheme("no-such-scheme")
    with pytest.raises(InputError, match="no such scheme file"):
        load_scheme(tmp_path / "missing.toml")


def test_a_name_becomes_a_safe_file_stem():
    assert parse_scheme({"name": "../../etc/x y", "step": [step()]}).name == "x-y"


def test_a_run_too_finely_cut_is_refused_before_any_work():
    scheme = parse_scheme({"step": [step(angle=0.0, dwell=1e-3)]}, "tiny.toml")
    with pytest.raises(InputError, match=f"more than {MAX_PIECES}"):
        scheme_pieces(scheme, 3600.0)


def test_a_scheme_that_does_not_close_is_measured():
    scheme = parse_scheme({"step": [step("z", 90.0)]})
    assert closure_error(scheme) == pytest.approx(math.pi / 2)
    pieces = scheme_pieces(scheme, 4 * scheme.period)  # continues where it ended: closes after 4 periods
    np.testing.assert_allclose(pieces[-1].end_attitude, np.eye(3), atol=1e-14)
