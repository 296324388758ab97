"""apply: the compensated recording and its check against gravity and the Earth rate at rest."""

import numpy as np

from casadi_sins.calibrate import calibrate
from casadi_sins.cli import main
from casadi_sins.data.description import read_recording
from casadi_sins.data.tables import write_table
from casadi_sins.model import registry as R
from casadi_sins.model.parameters import ParameterSet, natural_errors
from casadi_sins.sim import simulate, write_simulation
from casadi_sins.studies.apply import apply_table


def test_the_true_table_reproduces_gravity_and_the_earth_rate_on_a_noise_free_recording(short_problem):
    sim = simulate(short_problem, seed=3, noise=False)
    worst = apply_table(sim.recording, sim.truth).worst()
    assert worst["gravity_error_ug"] < 1e-3  # bar: 1 ug
    assert worst["earth_rate_error_deg_h"] < 1e-6  # bar: 0.001 deg/h
    assert worst["earth_rate_up_error_deg_h"] < 1e-6 and worst["earth_rate_horizontal_error_deg_h"] < 1e-6


def test_the_calibrated_table_reproduces_them_on_the_papers_noisy_recording(kang_sim, kang_nlp):
    applied = apply_table(kang_sim.recording, kang_nlp.parameters)
    worst = applied.worst()
    assert worst["gravity_error_ug"] < 1.0 and worst["earth_rate_error_deg_h"] < 1e-3
    # the errors are those of the noise of each 100 s mean, not more
    z = applied.check["gravity_error_ug"] / applied.check["gravity_noise_ug"]
    assert np.abs(z).max() < 4.5


def test_a_wrong_table_shows_in_the_check(short_problem):
    sim = simulate(short_problem, seed=3, noise=False)
    wrong = sim.truth.values.copy()
    wrong[R.ACCEL_SCALE] *= 1 + 20e-6  # 20 ppm: 20 ug at 1 g
    wrong[R.GYRO_BIAS] += np.radians(0.01) / 3600
    worst = apply_table(sim.recording, ParameterSet(wrong)).worst()
    assert 15 < worst["gravity_error_ug"] < 25 and worst["earth_rate_error_deg_h"] > 0.005


def test_apply_command_writes_a_recording_that_calibrates_to_identity(tmp_path, short_problem, capsys):
    sim = simulate(short_problem, seed=4)
    rec_path = write_simulation(sim, tmp_path / "rec")
    table = write_table(tmp_path / "truth.csv", sim.truth)
    assert main(["apply", str(table), str(rec_path), "--out", str(tmp_path / "out")]) == 0
    assert "worst static segment" in capsys.readouterr().out
    out = tmp_path / "out" / f"{sim.recording.file_stem}-compensated.toml"
    assert (tmp_path / "out" / f"{sim.recording.file_stem}-compensated-check.csv").exists()
    compensated = read_recording(out)
    result = calibrate(compensated)
    identity = np.where(R.SCALE_MASK, 1.0, 0.0)
    z = natural_errors(result.parameters, ParameterSet(identity)) / result.parameters.natural_sigma()
    assert np.abs(z).max() < 5, z


def test_apply_names_a_bad_table_in_one_line(tmp_path, short_problem, capsys):
    rec_path = write_simulation(simulate(short_problem, seed=4), tmp_path / "rec")
    (tmp_path / "bad.csv").write_text("parameter,unit,value\ngyro_bias_q,rad/s,1\n")
    assert main(["apply", str(tmp_path / "bad.csv"), str(rec_path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "bad.csv, line 2" in err and len(err.splitlines()) == 1


def test_the_extra_groups_are_applied_sample_by_sample(short_problem):
    """A unit with gyro g-sensitivity (deg/h per g) and scale asymmetry: its true table reproduces the Earth
    rate at rest; its 21 alone leave the g-sensitivity's bias of each position."""
    names = R.model_names(("gyro_gsens", "gyro_asym"))
    gsens = np.array([2, -3, 1, 4, -2, 1.5, -1, 2.5, -3.5]) * 1e-3 * R.GROUPS["gyro_gsens"].natural_scale
    values = np.concatenate([short_problem.truth.core, gsens, [3e-6, -4e-6, 5e-6]])
    problem = short_problem.__class__(**{**short_problem.__dict__, "truth": ParameterSet(values, names=names)})
    sim = simulate(problem, seed=3, noise=False)
    assert apply_table(sim.recording, sim.truth).worst()["earth_rate_error_deg_h"] < 1e-5
    assert apply_table(sim.recording, ParameterSet(sim.truth.core)).worst()["earth_rate_error_deg_h"] > 1e-3


def test_apply_gives_a_verdict_with_exit_3_beyond_the_noise(tmp_path, short_problem, capsys):
    """The right table passes (exit 0, every |z| within 5); a table 10 ppm off in the accelerometer scale factors
    (10 ug at 1 g against a noise of the mean near 1 ug: the wrong temperature's signature) fails with exit 3 and
    names the segments, the error and its sigma."""
    sim = simulate(short_problem, seed=5)
    rec_path = write_simulation(sim, tmp_path / "rec")
    result = calibrate(sim.recording)
    good = write_table(tmp_path / "good.csv", result.parameters)
    assert main(["apply", str(good), str(rec_path), "--out", str(tmp_path / "g")]) == 0
    printed = capsys.readouterr().out
    assert "verdict: PASS" in printed
    wrong = result.parameters.values.copy()
    wrong[R.ACCEL_SCALE] *= 1 + 10e-6
    bad = write_table(tmp_path / "bad.csv", ParameterSet(wrong, sigma=result.parameters.sigma))
    assert main(["apply", str(bad), str(rec_path), "--out", str(tmp_path / "b")]) == 3
    printed = capsys.readouterr().out
    assert "verdict: FAIL" in printed and "gravity error" in printed and "sigma (noise of the mean" in printed
    applied = apply_table(sim.recording, ParameterSet(wrong, sigma=result.parameters.sigma))
    verdict, reasons = applied.verdict()
    assert verdict == "fail" and len(reasons) >= 3
    assert (applied.check["gravity_table_ug"] > 0).all()  # the table's own sigma is part of what is judged
    right = apply_table(sim.recording, result.parameters)
    assert right.verdict() == ("pass", []) and right.check["gravity_z"].abs().max() < 5
