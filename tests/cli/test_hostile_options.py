"""Hostile option values (issue 35): every number option finite, seeds and worker counts bounded, each value the
command cannot use refused in one line (exit 2) before any work; nothing written, no input touched."""

import pytest

from casadi_sins.data.problem import default_problem_path
from casadi_sins.sim import simulate, write_simulation


@pytest.fixture(scope="module")
def unit(short_problem, tmp_path_factory):
    folder = tmp_path_factory.mktemp("opts")
    write_simulation(simulate(short_problem, seed=8, name="u"), folder)
    return folder


@pytest.mark.parametrize("args, needle", [
    (["analyze", "PROBLEM", "--gyro-arw-deg-rth", "nan"], "not a finite decimal number"),
    (["analyze", "PROBLEM", "--gyro-arw-deg-rth", "1_0"], "not a finite decimal number"),
    (["analyze", "PROBLEM", "--gyro-arw-deg-rth=-1"], "positive density"),
    (["montecarlo", "PROBLEM", "--workers", "1000000000000"], "at most four per core"),
    (["montecarlo", "PROBLEM", "--workers", "0"], "--workers"),
    (["simulate", "PROBLEM", "--seed", "-1"], "a random seed"),
    (["montecarlo", "PROBLEM", "--runs", "1000000000000"], "Monte Carlo runs"),
    (["navcheck", "PROBLEM", "--params", "TABLE", "--duration-s", "1e300"], "--duration-s"),
    (["navcheck", "PROBLEM", "--params", "TABLE", "--align-s=-1"], "--align-s"),
    (["modulate", "--scheme", "strapdown", "--params", "TABLE", "--hours", "1", "--latitude", "30", "--height",
      "1e300"], "height"),
    (["calibrate", "REC", "--max-iterations", "1000000000000"], "iterations"),
    (["calibrate", "REC"], "required: --out"),
])
def test_a_number_no_command_can_use_is_one_line(unit, tmp_path, cli_keeps_inputs, args, needle):
    table = tmp_path / "t.csv"
    table.write_text((unit / "u.truth.csv").read_text())
    names = {"PROBLEM": default_problem_path(), "TABLE": table, "REC": unit / "u.toml"}
    args = [names.get(a, a) for a in args]
    out = [] if args[:2] == ["calibrate", unit / "u.toml"] and len(args) == 2 else (
        ["--out", tmp_path / "o.csv"] if args[0] == "calibrate" else ["--out", tmp_path / "o"])
    cli_keeps_inputs([*args, *out], [unit / "u.toml", unit / "u.csv", table], 2, needle)
    assert not (tmp_path / "o").exists() and not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("options, needle", [(["--rate", "0"], "--rate"), (["--gravity=-1"], "--gravity"),
                                             (["--height", "nan"], "finite")])
def test_segment_never_writes_a_description_the_reader_refuses(unit, tmp_path, cli_keeps_inputs, options, needle):
    args = ["segment", unit / "u.csv", "--latitude", "37.5", *options, "--out", tmp_path / "s.toml"]
    if "--rate" not in options:
        args += ["--rate", "100"]
    cli_keeps_inputs(args, [unit / "u.csv"], 2, needle)
    assert not (tmp_path / "s.toml").exists()
