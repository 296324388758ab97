"""A thermal problem simulated: one recording per setpoint with its temperature, the truth following the model."""

from __future__ import annotations

import numpy as np

from casadi_sins.cli import main
from casadi_sins.data.description import read_recording
from casadi_sins.data.tables import read_table
from casadi_sins.data.thermal import read_thermal
from casadi_sins.model.parameters import natural_errors

PROBLEMS = __import__("pathlib").Path(__file__).resolve().parents[2] / "problems"


def _short_thermal_problem(tmp_path):
    text = (PROBLEMS / "thermal-kang2013.toml").read_text()
    text = text.replace("static_s = 100.0", "static_s = 8.0").replace("rotation_s = 10.0", "rotation_s = 3.0")
    text = text.replace("setpoints_c = [-30.0, -10.0, 10.0, 25.0, 40.0, 60.0]", "setpoints_c = [-30.0, 60.0]")
    path = tmp_path / "thermal.toml"
    path.write_text(text)
    return path


def test_simulate_writes_one_recording_per_setpoint_with_its_conditions(tmp_path):
    out = tmp_path / "sim"
    assert main(["simulate", str(_short_thermal_problem(tmp_path)), "--out", str(out), "--no-noise"]) == 0
    model = read_thermal(out / "thermal-truth.csv")
    for stem, temperature in (("thermal-kang2013-m30C", -30.0), ("thermal-kang2013-60C", 60.0)):
        rec = read_recording(out / f"{stem}.toml")
        assert rec.conditions.temperature_c == temperature and rec.conditions.unit_id == "SN-THERMAL-1"
        truth = read_table(out / f"{stem}.truth.csv")
        np.testing.assert_allclose(truth.values, model.values_at(temperature), rtol=1e-15, atol=0)
    cold, hot = (read_table(out / f"{s}.truth.csv") for s in ("thermal-kang2013-m30C", "thermal-kang2013-60C"))
    change = natural_errors(hot, cold)  # 90 degC apart: the problem's a1 (+ a2 * 90 * 70 for the curved ones)
    assert abs(change[0] - (-0.8 * 90 + 0.01 * (35 ** 2 - 55 ** 2))) < 1e-6  # accel_bias_x, ug
    assert abs(change[9] - (0.0004 * 90 + 0.000004 * (35 ** 2 - 55 ** 2))) < 1e-9  # gyro_bias_x, deg/h


def test_simulate_refuses_single_recording_options_for_a_thermal_problem(tmp_path, capsys):
    assert main(["simulate", str(_short_thermal_problem(tmp_path)), "--out", str(tmp_path / "s"), "--name", "x"]) == 2
    assert "single recording" in capsys.readouterr().err


def test_apply_thermal_at_the_recordings_temperature_is_the_table_at_that_temperature(tmp_path, capsys):
    """apply --thermal without --temperature-c takes the recording's [conditions]: the same compensated recording
    as applying the true table of that setpoint; --temperature-c elsewhere gives another."""
    sim = tmp_path / "sim"
    assert main(["simulate", str(_short_thermal_problem(tmp_path)), "--out", str(sim), "--no-noise"]) == 0
    rec = str(sim / "thermal-kang2013-m30C.toml")
    assert main(["apply", "--thermal", str(sim / "thermal-truth.csv"), rec, "--out", str(tmp_path / "a")]) == 0
    assert "-30 degC (from the recording's [conditions])" in capsys.readouterr().err  # a note: standard error
    assert main(["apply", str(sim / "thermal-kang2013-m30C.truth.csv"), rec, "--out", str(tmp_path / "b")]) == 0
    a, b = (read_recording(tmp_path / d / "thermal-kang2013-m30C-compensated.toml") for d in "ab")
    np.testing.assert_allclose(a.accel, b.accel, rtol=1e-13, atol=1e-18)
    np.testing.assert_allclose(a.gyro, b.gyro, rtol=1e-13, atol=1e-18)
    assert main(["apply", "--thermal", str(sim / "thermal-truth.csv"), "--temperature-c", "60", rec,
                 "--out", str(tmp_path / "c")]) == 3  # the wrong temperature: gravity far beyond the noise, a verdict
    assert "verdict: FAIL" in capsys.readouterr().out
    c = read_recording(tmp_path / "c" / "thermal-kang2013-m30C-compensated.toml")
    assert not np.allclose(c.accel, a.accel, rtol=1e-9, atol=0)
    assert main(["apply", str(sim / "thermal-kang2013-m30C.truth.csv"), rec, "--out", str(tmp_path / "d"),
                 "--temperature-c", "60"]) == 2  # a table is of one temperature


def test_apply_thermal_sample_by_sample_at_the_temperature_column(tmp_path):
    """A recording with a temperature column (no [conditions]) is compensated at each sample's temperature."""
    import dataclasses

    from casadi_sins.core.files import write_files
    from casadi_sins.data.conditions import Conditions
    from casadi_sins.data.description import recording_files
    from casadi_sins.model.output import compensate

    sim = tmp_path / "sim"
    assert main(["simulate", str(_short_thermal_problem(tmp_path)), "--out", str(sim), "--no-noise"]) == 0
    rec = read_recording(sim / "thermal-kang2013-m30C.toml")
    ramp = np.linspace(-30.0, 20.0, len(rec.time))
    write_files(recording_files(dataclasses.replace(rec, conditions=Conditions(), temperature=ramp),
                                tmp_path / "ramp.toml"))
    assert main(["apply", "--thermal", str(sim / "thermal-truth.csv"), str(tmp_path / "ramp.toml"),
                 "--out", str(tmp_path / "a")]) == 3  # the data are of -30 degC, not of the ramp: the check fails
    got = read_recording(tmp_path / "a" / "thermal-kang2013-m30C-compensated.toml")
    model = read_thermal(sim / "thermal-truth.csv")
    for k in (0, len(ramp) // 2, len(ramp) - 1):
        dtheta, dv = compensate(rec.gyro[k:k + 1], rec.accel[k:k + 1], model.values_at(round(ramp[k], 2)), rec.dt)
        np.testing.assert_allclose(got.gyro[k], dtheta[0], rtol=1e-12, atol=1e-20)
        np.testing.assert_allclose(got.accel[k], dv[0], rtol=1e-12, atol=1e-20)


def test_the_temperature_of_apply_thermal_is_given_else_the_conditions_else_none_refused(tmp_path):
    """The study chooses the temperature: a given one first (named as the caller names it), then the recording's
    [conditions]; with neither and no temperature column it refuses, naming the recording and what to give."""
    import dataclasses

    import pytest

    from casadi_sins.core.errors import InputError
    from casadi_sins.studies.thermal.apply import apply_thermal_at_recording

    sim = tmp_path / "sim"
    assert main(["simulate", str(_short_thermal_problem(tmp_path)), "--out", str(sim), "--no-noise"]) == 0
    rec, model = read_recording(sim / "thermal-kang2013-m30C.toml"), read_thermal(sim / "thermal-truth.csv")
    given = apply_thermal_at_recording(rec, model, "M.csv", 60.0, "--temperature-c")
    assert given.notes[0] == "thermal model M.csv evaluated at 60 degC (from --temperature-c)"
    own = apply_thermal_at_recording(rec, model, "M.csv")
    assert own.notes[0].endswith("-30 degC (from the recording's [conditions])")
    assert not np.allclose(given.recording.accel, own.recording.accel, rtol=1e-9, atol=0)
    bare = dataclasses.replace(rec, conditions=dataclasses.replace(rec.conditions, temperature_c=None),
                               temperature=None)
    with pytest.raises(InputError, match="no temperature.*give --temperature-c"):
        apply_thermal_at_recording(bare, model, "M.csv", given_as="--temperature-c")
