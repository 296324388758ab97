"""The command line: outputs that another program can read back, clear errors, exit codes."""

import numpy as np

from casadi_sins.cli import main
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.data.problem import load_problem
from casadi_sins.data.tables import read_table
from casadi_sins.sim import simulate


def test_simulate_writes_a_recording_and_truth_that_read_back(tmp_path, capsys):
    assert main(["simulate", "--seed", "3", "--out", str(tmp_path), "--no-noise"]) == 0
    rec = read_recording(tmp_path / "kang2013-seed3.toml")
    truth = read_table(tmp_path / "kang2013-seed3.truth.csv")
    assert len(rec.time) == 129000 and rec.site.gravity is None
    assert (tmp_path / "kang2013-seed3.truth.csv").read_text().startswith("parameter,unit,value\n")
    np.testing.assert_allclose(truth.values, load_problem().truth.values, rtol=1e-12)  # Table 2, to 12 digits
    assert main(["validate", str(tmp_path / "kang2013-seed3.toml")]) == 0
    assert "group 3: NUE -+X-> NED" in capsys.readouterr().out
    assert not list(tmp_path.glob(".*tmp"))  # nothing half-written left behind


def test_bad_recording_gives_one_line_error_and_status_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('format = "sins-recording/1"\nname = "x"\ndata = "x.csv"\n[site]\nlatitude_deg = 10\nheight_m = 0\n')
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.toml" in err and "rate_hz" in err


def test_rough_writes_a_parameter_table(tmp_path, short_problem):

    path = write_recording(simulate(short_problem, seed=0).recording, tmp_path / "r.toml")
    assert main(["rough", str(path), "--out", str(tmp_path / "rough.csv")]) == 0
    rough = read_table(tmp_path / "rough.csv")
    assert rough["gyro_misalign_xy"] == 0.0 and rough["accel_scale_y"] > 0


def test_calibrate_writes_the_table_with_its_report_and_strict_refuses_on_a_warning(tmp_path, kang_sim, capsys):
    """Every doubt reaches the report files (issue 9); --strict turns it into a failure with no output."""
    import json


    path = write_recording(kang_sim.recording, tmp_path / "r.toml")
    csv = path.with_suffix(".csv")
    lines = csv.read_text().splitlines()
    csv.write_text("\n".join([lines[0]] + [f"{k / 100.0005:.9f}," + line.split(",", 1)[1]
                                           for k, line in enumerate(lines[1:], start=1)]) + "\n")
    out = tmp_path / "out" / "params.csv"
    assert main(["calibrate", str(path), "--out", str(out), "--strict"]) == 2
    assert "--strict and 1 warning(s)" in capsys.readouterr().err and not (tmp_path / "out").exists()
    assert main(["calibrate", str(path), "--out", str(out), "--report", str(tmp_path / "rep")]) == 0
    report = json.loads((tmp_path / "out" / "params.report.json").read_text())
    assert any("-5 ppm" in w for w in report["warnings"]) and report["ipopt"]["status"] == "Solve_Succeeded"
    assert report["noise"]["sources"]["accel_vrw"] == "raw data" and len(report["parameters"]) == 21
    assert "-5 ppm" in (tmp_path / "out" / "params.report.md").read_text()
    assert (tmp_path / "rep" / f"{kang_sim.recording.name}-nlp-residuals.png").stat().st_size > 10000
    printed = capsys.readouterr()
    assert "WARNING" in printed.err
    assert "note: bias instability is not modelled" in printed.err  # no datasheet: a diagnostic, and in the report
    assert "Bias instability is not modelled" in (tmp_path / "out" / "params.report.md").read_text()
    wander = report["noise"]["bias_wander"]  # issue 16: what the static data show, per sensor, in natural units
    assert set(wander) == {"accel", "gyro"} and not any(w["included"] for w in wander.values())
    assert 0.0 < wander["accel"]["upper"] < 10.0 and wander["accel"]["tau_s"] > 300.0  # ug, s
    assert read_table(out).sigma is not None
