"""Predicted accuracy (covariance analysis) and the Monte Carlo command."""

import numpy as np
import pandas as pd
import pytest

from casadi_sins.cli import main
from casadi_sins.data.tables import read_table
from casadi_sins.model import registry as R
from casadi_sins.studies.montecarlo import run, summary
from casadi_sins.studies.prediction import predict_problem, predict_problem_ils


@pytest.fixture(scope="module")
def kang_prediction(kang_problem):
    return predict_problem(kang_problem)


def test_prediction_matches_the_nlp_sigma_of_a_noisy_run(kang_prediction, kang_nlp):
    """The predicted sigma (no data) is what the NLP reports from data, within the noise of its
    noise-level estimate (the accelerometer level from ~3600 residuals, the gyro level from 36)."""

    from_data = kang_nlp.parameters.natural_sigma()
    ratio = from_data / kang_prediction.sigma_natural
    accel = np.r_[R.ACCEL_BIAS, R.ACCEL_SCALE, R.ACCEL_MISALIGN]
    np.testing.assert_allclose(ratio[accel], 1.0, atol=0.1)
    np.testing.assert_allclose(ratio, 1.0, atol=0.5)


def test_prediction_scales_with_the_noise(kang_problem, kang_prediction):
    quiet = predict_problem(kang_problem.with_changes(accel_noise_ug=25.0, gyro_noise_deg_h=0.005))
    np.testing.assert_allclose(quiet.sigma_natural, kang_prediction.sigma_natural / 2, rtol=0.02)


def test_a_schedule_that_never_turns_about_x_is_weak_in_gyro_scale_x(short_problem):
    import dataclasses

    # groups 1 (about Z) and 2 (about Y) only: the x gyro sees no rotation, only the Earth rate
    two = dataclasses.replace(short_problem, groups=(short_problem.groups[0], short_problem.groups[1]))
    pred = predict_problem(two)
    full = predict_problem(short_problem)
    assert pred.sigma_natural[R.NAMES.index("gyro_scale_x")] > 3 * full.sigma_natural[R.NAMES.index("gyro_scale_x")]
    assert "gyro_scale_x" in pred.weak and not full.weak


def test_analyze_command_writes_tables_in_the_parameter_table_layout(tmp_path, short_problem):
    from pathlib import Path

    problems = Path(__file__).resolve().parents[2] / "problems"
    assert main(["analyze", str(problems / "kang2013.toml"), str(problems / "xie2011-19pos.toml"),
                 "--out", str(tmp_path)]) == 0
    table = read_table(tmp_path / "kang2013-predicted.csv")
    assert table.sigma is not None and np.all(table.sigma > 0)
    frame = pd.read_csv(tmp_path / "schedules-predicted.csv")
    assert {"kang2013 sigma", "xie2011-19pos sigma"} <= set(frame.columns)
    assert (tmp_path / "schedules-predicted.png").exists()


def test_monte_carlo_on_dask_matches_local_processes(short_problem):
    pytest.importorskip("dask.distributed")
    local = run(short_problem, [1, 2], ("ils",), workers=2)
    on_dask = run(short_problem, [1, 2], ("ils",), workers=2, scheduler="local")
    key = ["seed", "parameter"]
    a = local.sort_values(key).reset_index(drop=True)
    b = on_dask.sort_values(key).reset_index(drop=True)
    np.testing.assert_allclose(a["error"], b["error"], rtol=1e-9, atol=1e-12)
    assert len(summary(a)) == R.N_PARAMS


def test_montecarlo_command(tmp_path, short_problem, monkeypatch):

    from casadi_sins.cli import commands

    monkeypatch.setattr(commands, "load_problem", lambda path=None: short_problem)
    assert main(["montecarlo", "--runs", "2", "--solvers", "ils", "--out", str(tmp_path)]) == 0
    frame = pd.read_csv(tmp_path / "short-montecarlo.csv")
    assert {"rms_error", "predicted_sigma", "rms_over_predicted"} <= set(frame.columns)
    assert (tmp_path / "short-montecarlo.png").exists()


def test_the_ils_prediction_is_the_ils_sigma_of_a_noisy_run(kang_problem, kang_ils):
    """The ILS's own prediction (its equations' covariance at the truth, no data) is what it reports from data
    within the noise of the raw-data estimate (issue 40: design --solvers nlp ils)."""
    predicted = predict_problem_ils(kang_problem)
    ratio = kang_ils.parameters.natural_sigma() / predicted
    assert np.all((ratio > 0.85) & (ratio < 1.15)), ratio
