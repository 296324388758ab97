"""Never destroy a recording (issue 35) and outputs that agree (issue 36, item 1): each reproducer as a user
ran it, with its exit status, one line on standard error and the SHA-256 of every input unchanged."""

import json
import shutil

import pandas as pd
import pytest

from casadi_sins.cli import main
from casadi_sins.sim import simulate, write_simulation


@pytest.fixture(scope="module")
def unit(short_problem, tmp_path_factory):
    """A recording ``u1.toml`` + ``u1.csv`` (copied into each test's folder)."""
    folder = tmp_path_factory.mktemp("unit")
    write_simulation(simulate(short_problem, seed=21, name="u1"), folder)
    return folder


def place(unit, folder, name="u1", data=None):
    """The recording in ``folder`` as ``name.toml``, its samples as ``data`` (default ``name.csv``)."""
    folder.mkdir(parents=True, exist_ok=True)
    data = data or f"{name}.csv"
    text = (unit / "u1.toml").read_text().replace('data = "u1.csv"', f'data = "{data}"')
    (folder / f"{name}.toml").write_text(text.replace('name = "u1"', f'name = "{name}"'))
    shutil.copyfile(unit / "u1.csv", folder / data)
    return folder / f"{name}.toml", folder / data


def sheet(path, gyro_bias_x):
    path.write_text(f'format = "casadi-sins-tolerance/1"\n[accept.sigma]\ngyro_bias_x = {gyro_bias_x!r}\n')
    return path


def test_batch_of_the_units_folder_into_its_parent_keeps_every_recording(unit, tmp_path, cli_keeps_inputs):
    """batch X/units --out X: the recordings kept in X/units/ as batch lays them out."""
    toml, data = place(unit, tmp_path / "X" / "units")
    cli_keeps_inputs(["batch", tmp_path / "X" / "units", "--out", tmp_path / "X", "--workers", "1", "--quiet"],
                     [toml, data], 2, "u1.csv", "input of this command", "samples of")
    assert not (tmp_path / "X" / "fleet.csv").exists()


def test_batch_into_its_own_folder_keeps_a_data_file_named_fleet_csv(unit, tmp_path, cli_keeps_inputs):
    toml, data = place(unit, tmp_path / "D", data="fleet.csv")
    cli_keeps_inputs(["batch", tmp_path / "D", "--out", tmp_path / "D", "--workers", "1", "--quiet"], [toml, data],
                     2, "fleet.csv", "input of this command")
    assert sorted(p.name for p in (tmp_path / "D").iterdir()) == ["fleet.csv", "u1.toml"]


def test_a_recording_named_explicitly_inside_out_units_is_never_deleted(unit, tmp_path, cli_keeps_inputs):
    toml, data = place(unit, tmp_path / "OUT" / "units")
    data.write_text(data.read_text()[:200])  # a unit that fails: its samples end in the second line
    cli_keeps_inputs(["batch", toml, "--out", tmp_path / "OUT", "--workers", "1", "--quiet"], [toml, data], 2,
                     "u1.csv", "input")


def test_a_failed_unit_loses_its_stale_outputs_but_never_its_samples(unit, tmp_path, cli_keeps_inputs):
    toml, data = place(unit, tmp_path / "OUT" / "units", data="u1-samples.csv")
    lines = data.read_text().splitlines()
    data.write_text("\n".join(lines[:40]) + "\n")  # too short to calibrate
    units = tmp_path / "OUT" / "units"
    for stale in ("u1.csv", "u1.report.json", "u1.certificate.html", "u1.compensation.json"):
        (units / stale).write_text("an earlier run")
    cli_keeps_inputs(["batch", toml, "--out", tmp_path / "OUT", "--workers", "1", "--quiet"], [toml, data], 2,
                     lines=0)  # the failure is the fleet table's
    assert sorted(p.name for p in units.iterdir()) == ["u1-samples.csv", "u1.toml"]
    assert pd.read_csv(tmp_path / "OUT" / "fleet.csv")["status"].tolist() == ["failed"]


def test_an_unparsable_toml_in_a_batch_folder_is_a_failed_unit(unit, tmp_path, cli_keeps_inputs):
    toml, data = place(unit, tmp_path / "recs")
    (tmp_path / "recs" / "broken.toml").write_text('format = "sins-recording/1"\nname = [\n')
    err = cli_keeps_inputs(["batch", tmp_path / "recs", "--out", tmp_path / "out", "--workers", "1", "--quiet"],
                           [toml, data, tmp_path / "recs" / "broken.toml"], 2, lines=0)
    fleet = pd.read_csv(tmp_path / "out" / "fleet.csv", keep_default_na=False).set_index("unit_id")
    assert fleet.loc["broken", "status"] == "failed" and "not valid TOML" in fleet.loc["broken", "message"]
    assert fleet.loc["u1", "status"] != "failed" and err == ""


def test_a_failing_rerun_leaves_no_pass_certificate(unit, tmp_path, cli_keeps_inputs):
    """calibrate --certificate with a loose sheet, then the same with a tight one and no --certificate (exit 3)."""
    toml, data = place(unit, tmp_path)
    loose, tight = sheet(tmp_path / "loose.toml", 1.0), sheet(tmp_path / "tight.toml", 1e-12)
    table = tmp_path / "SN1001.csv"
    first = ["calibrate", toml, "--out", table, "--unit-id", "SN1001", "--export", "json", "c"]
    cli_keeps_inputs(first + ["--tolerance", loose, "--certificate"], [toml, data, loose], 0)
    certificate = tmp_path / "SN1001.certificate.html"
    assert "PASS" in certificate.read_text() and (tmp_path / "SN1001.compensation.h").exists()
    cli_keeps_inputs(["calibrate", toml, "--out", table, "--unit-id", "SN1001", "--tolerance", tight],
                     [toml, data, tight], 3)
    assert json.loads((tmp_path / "SN1001.report.json").read_text())["verdict"] == "fail"
    assert not certificate.exists()
    assert not (tmp_path / "SN1001.compensation.h").exists() and not (tmp_path / "SN1001.compensation.json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["SN1001.csv", "SN1001.report.json", "SN1001.report.md",
                                                          "loose.toml", "tight.toml", "u1.csv", "u1.toml"]


def test_a_failing_batch_rerun_leaves_no_pass_certificate_beside_the_fleet(unit, tmp_path, cli_keeps_inputs):
    toml, data = place(unit, tmp_path / "recs")
    loose, tight = sheet(tmp_path / "loose.toml", 1.0), sheet(tmp_path / "tight.toml", 1e-12)
    args = ["batch", tmp_path / "recs", "--out", tmp_path / "out", "--workers", "1", "--quiet"]
    cli_keeps_inputs(args + ["--tolerance", loose, "--certificate"], [toml, data, loose], 0)
    certificate = tmp_path / "out" / "units" / "u1.certificate.html"
    assert "PASS" in certificate.read_text()
    cli_keeps_inputs(args + ["--tolerance", tight], [toml, data, tight], 3)
    assert "| fail |" in (tmp_path / "out" / "fleet.md").read_text()
    assert not certificate.exists()
    # with --certificate the rerun's certificate says what the fleet says
    cli_keeps_inputs(args + ["--tolerance", tight, "--certificate"], [toml, data, tight], 3)
    assert "FAIL" in certificate.read_text() and "PASS" not in certificate.read_text()


def test_calibrate_onto_an_input_of_its_output_set_is_refused_before_computing(unit, tmp_path, cli_keeps_inputs):
    toml, data = place(unit, tmp_path)
    noise = tmp_path / "P.compensation.json"  # an input named as one of the exports of P.csv
    noise.write_text("gyro_arw_deg_rth = 0.002\n")
    cli_keeps_inputs(["calibrate", toml, "--out", tmp_path / "P.csv", "--noise", noise], [toml, data, noise], 2,
                     "P.compensation.json", "input of this command")
    assert not (tmp_path / "P.csv").exists()


def test_a_fifo_named_toml_in_a_batch_folder_is_a_failed_unit_not_a_hang(unit, tmp_path, cli_keeps_inputs):
    import os

    toml, data = place(unit, tmp_path / "recs")
    os.mkfifo(tmp_path / "recs" / "x.toml")
    cli_keeps_inputs(["batch", tmp_path / "recs", "--out", tmp_path / "out", "--workers", "1", "--quiet"],
                     [toml, data], 2, lines=0)
    fleet = pd.read_csv(tmp_path / "out" / "fleet.csv", keep_default_na=False).set_index("unit_id")
    assert "not a regular file" in fleet.loc["x", "message"]
