"""The studies under hostile input (issue 35): sizes judged before anything is allocated, numbers beyond any
sensor refused when read, setpoints too close to fit, dates no calibration has; one line, exit 2, inputs kept."""

import json
import time

import numpy as np
import pytest

from casadi_sins.data.problem import default_problem_path
from casadi_sins.data.tables import write_table
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.model.registry import NAMES, natural_scale_of, relative_mask


@pytest.fixture()
def problem(tmp_path):
    path = tmp_path / "kang2013.toml"
    path.write_text(default_problem_path().read_text())
    return path


@pytest.mark.parametrize("total_s, needles", [
    ("1e12", ["--total-s 1e+12", "--evaluations 300", "search budget", "at most"]),
    ("1e7", ["--total-s 1e+07", "search budget"]),
])
def test_design_budgets_are_judged_before_any_prediction(problem, tmp_path, cli_keeps_inputs, total_s, needles):
    started = time.perf_counter()
    err = cli_keeps_inputs(["design", problem, "--total-s", total_s, "--out", tmp_path / "d", "--quiet"], [problem], 2,
                           *needles)
    assert "shorter recording" not in err and time.perf_counter() - started < 10.0
    assert not (tmp_path / "d").exists()


def test_design_memory_of_one_prediction_is_judged_first(problem, tmp_path, cli_keeps_inputs, monkeypatch):
    from casadi_sins.studies.design import run

    monkeypatch.setattr(run, "memory_available", lambda: 2e9)
    cli_keeps_inputs(["design", problem, "--total-s", "1e6", "--evaluations", "1", "--out", tmp_path / "d", "--quiet"],
                     [problem], 2, "--total-s", "GB of memory", "at most")


@pytest.mark.parametrize("args", [["design", "PROBLEM", "--total-s", "1290", "--verify", "1000000000"],
                                  ["montecarlo", "PROBLEM", "--runs", "1000000000"]])
def test_monte_carlo_runs_are_bounded_before_any_list(problem, tmp_path, cli_keeps_inputs, args):
    started = time.perf_counter()
    args = [problem if a == "PROBLEM" else a for a in args] + ["--out", tmp_path / "mc", "--quiet"]
    cli_keeps_inputs(args, [problem], 2, "1000000000", "100000")
    assert time.perf_counter() - started < 10.0


def test_a_noise_of_1e300_is_refused_when_read(problem, tmp_path, cli_keeps_inputs):
    problem.write_text(problem.read_text().replace("accel_noise_ug = 50.0", "accel_noise_ug = 1e300"))
    cli_keeps_inputs(["design", problem, "--total-s", "1290", "--out", tmp_path / "d", "--quiet"], [problem], 2,
                     "accel_noise_ug", "beyond any inertial sensor")
    cli_keeps_inputs(["analyze", problem, "--accel-vrw-ug-rthz", "1e300", "--out", tmp_path / "a"], [problem], 2,
                     "--accel-vrw-ug-rthz", "beyond any inertial sensor")
    from casadi_sins.core.errors import InputError
    from casadi_sins.data.datasheet import read_datasheet

    sheet = tmp_path / "datasheet.toml"
    sheet.write_text("gyro_arw_deg_rth = 1e300\n")
    with pytest.raises(InputError, match="gyro_arw_deg_rth 1e.300 is beyond any inertial sensor"):
        read_datasheet(sheet)


def _tables(folder, temperatures, dates=None):
    """Parameter tables with sigma and a companion report (temperature or date in its conditions)."""
    rng = np.random.default_rng(2)
    size = natural_scale_of(NAMES) * np.where(relative_mask(NAMES), 1e-5, 1.0)
    nominal = np.where(relative_mask(NAMES), 1e-5, 0.0)
    paths = []
    for k, t in enumerate(temperatures):
        params = ParameterSet(nominal + size * rng.normal(size=len(NAMES)) * 0.1, sigma=size * 0.2)
        path = folder / f"T{k}.csv"
        write_table(path, params)
        conditions = {"temperature_c": t} if t is not None else {}
        if dates:
            conditions["date"] = dates[k]
        report = {"format": "casadi-sins-report/1", "created": "2026-01-01T00:00:00+00:00", "unit_id": "SN7",
                  "conditions": conditions}
        (folder / f"T{k}.report.json").write_text(json.dumps(report))
        paths.append(path)
    return paths


@pytest.mark.parametrize("suffix", [".", "1.2.3", "", "+-1"])
def test_a_temperature_after_the_at_sign_that_is_no_number_is_one_line(tmp_path, cli_keeps_inputs, suffix):
    paths = _tables(tmp_path, [None, None])
    cli_keeps_inputs(["thermal", f"{paths[0]}@{suffix}", f"{paths[1]}@35", "--out", tmp_path / "out"], paths, 2,
                     "T0.csv", "must be a number of degC")
    assert not (tmp_path / "out").exists()


def test_setpoints_closer_than_a_chamber_can_tell_are_refused(tmp_path, cli_keeps_inputs):
    paths = _tables(tmp_path, [25.0, 25.0 + 1e-12, 25.05])
    cli_keeps_inputs(["thermal", *paths, "--out", tmp_path / "out"], paths, 2, "1 distinct temperature setpoint",
                     "within 0.1 degC")
    assert not (tmp_path / "out").exists()
    cli_keeps_inputs(["thermal", *paths[:2], f"{paths[2]}@45", "--out", tmp_path / "out", "--no-plots"], paths, 0)
    coefficients = json.loads((tmp_path / "out" / "thermal.json").read_text())
    assert coefficients  # a model of two setpoints 20 degC apart


def test_history_of_a_recording_dated_9999_is_one_line(tmp_path, cli_keeps_inputs):
    paths = _tables(tmp_path, [None, None], dates=["9999-12-31", "2024-01-01"])
    cli_keeps_inputs(["history", *paths, "--out", tmp_path / "out"], paths + [tmp_path / "T0.report.json"], 2,
                     "T0.report.json", "years 1970 to 2199")
    assert not (tmp_path / "out").exists()


def test_a_recording_dated_9999_is_refused_when_read(short_problem, tmp_path, cli_keeps_inputs):
    from casadi_sins.sim import simulate, write_simulation

    write_simulation(simulate(short_problem, seed=2, name="d"), tmp_path)
    toml = tmp_path / "d.toml"
    toml.write_text(toml.read_text() + '\n[conditions]\ndate = "9999-12-31"\n')
    cli_keeps_inputs(["validate", toml], [toml, tmp_path / "d.csv"], 2, "[conditions] date", "years 1970 to 2199")


def test_a_problem_too_long_to_simulate_is_refused_before_allocating(problem, tmp_path, cli_keeps_inputs):
    """A 2 kB problem file asking for 6e8 samples (the reader's own limit is 1e9): one line naming the memory."""
    problem.write_text(problem.read_text().replace("static_s = 100.0", "static_s = 500000.0"))
    started = time.perf_counter()
    for command in (["simulate", problem], ["analyze", problem]):
        cli_keeps_inputs([*command, "--out", tmp_path / "o"], [problem], 2, "6e+08 samples", "GB of memory")
    assert time.perf_counter() - started < 20.0 and not (tmp_path / "o").exists()
