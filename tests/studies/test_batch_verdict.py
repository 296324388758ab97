"""batch with a tolerance sheet: a verdict per unit, the exit status, a folder argument, no stale outputs."""

import json

import pandas as pd
import pytest

from casadi_sins.cli import main
from casadi_sins.data.tables import read_table
from casadi_sins.model import registry as R
from casadi_sins.sim import simulate, write_simulation


@pytest.fixture(scope="module")
def line(tmp_path_factory, short_problem):
    """Three units in a folder, the gyro-bias sigma of each, and a folder with a corrupt recording only."""
    root = tmp_path_factory.mktemp("verdict")
    for k in range(3):
        write_simulation(simulate(short_problem, seed=30 + k, name=f"U{k}"), root / "recs")
    (root / "recs" / "notes.toml").write_text('title = "not a recording"\n')  # skipped in a folder
    out = root / "plain"
    assert main(["batch", str(root / "recs"), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    sigma = {k: read_table(out / "units" / f"U{k}.csv").natural_sigma()[list(R.NAMES).index("gyro_bias_x")]
             for k in range(3)}
    return root, sigma


def test_a_folder_argument_calibrates_every_recording_in_it(line):
    root, _ = line
    fleet = pd.read_csv(root / "plain" / "fleet.csv", keep_default_na=False)
    assert sorted(fleet["unit_id"]) == ["U0", "U1", "U2"] and (fleet["status"] != "failed").all()


def test_a_unit_out_of_tolerance_gives_the_verdict_column_and_exit_3(line, capsys):
    root, sigma = line
    cut = float(sorted(sigma.values())[1]) * 1.000001  # between the units: the largest-sigma one fails
    sheet = root / "sheet.toml"
    sheet.write_text(f'format = "casadi-sins-tolerance/1"\n[accept.sigma]\ngyro_bias_x = {cut!r}\n')
    out = root / "judged"
    status = main(["batch", str(root / "recs"), "--out", str(out), "--tolerance", str(sheet), "--workers", "1",
                   "--quiet"])
    assert status == 3
    fleet = pd.read_csv(out / "fleet.csv", keep_default_na=False).set_index("unit_id")
    expected = {f"U{k}": "fail" if s > cut else "pass" for k, s in sigma.items()}
    assert fleet["verdict"].to_dict() == expected
    assert "verdict" in (out / "fleet.md").read_text()
    worst = max(sigma, key=sigma.get)
    assert json.loads((out / "units" / f"U{worst}.report.json").read_text())["verdict"] == "fail"
    # a resumed batch against another sheet judges again
    sheet.write_text('format = "casadi-sins-tolerance/1"\n[accept.sigma]\ngyro_bias_x = 1.0\n')
    assert main(["batch", str(root / "recs"), "--out", str(out), "--tolerance", str(sheet), "--workers", "1",
                 "--quiet"]) == 0
    assert set(pd.read_csv(out / "fleet.csv")["verdict"]) == {"pass"}


def test_every_unit_failing_is_no_internal_error_and_leaves_no_stale_table(tmp_path, line, capsys):
    root, _ = line
    bad = tmp_path / "bad"
    bad.mkdir()
    text = (root / "recs" / "U0.toml").read_text()
    (bad / "B0.toml").write_text(text.replace("U0.csv", "B0.csv"))
    (bad / "B0.csv").write_text("time,gyro_x\n0,1\n")
    out = tmp_path / "out"
    (out / "units").mkdir(parents=True)
    (out / "units" / "B0.csv").write_text("stale")
    (out / "units" / "B0.report.json").write_text("{}")
    assert main(["batch", str(bad), "--out", str(out), "--workers", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "internal error" not in err
    assert not (out / "units" / "B0.csv").exists() and not (out / "units" / "B0.report.json").exists()
    assert pd.read_csv(out / "fleet.csv")["status"].tolist() == ["failed"]


def test_a_changed_sheet_judges_the_stored_tables_again_without_calibrating(line, capsys, monkeypatch):
    """With another sheet a resumed batch judges every stored table again (no calibration: the calibration is
    made to fail if called); each unit out of tolerance has a message saying why, in fleet.md and on screen; the
    certificates follow the new verdict (their plots carried over), their table hash and number anew."""
    import casadi_sins.studies.batch as B

    root, sigma = line
    out = root / "rejudge"
    sheet = root / "loose.toml"
    sheet.write_text('format = "casadi-sins-tolerance/1"\n[accept.sigma]\ngyro_bias_x = 1.0\n')
    assert main(["batch", str(root / "recs"), "--out", str(out), "--tolerance", str(sheet), "--certificate",
                 "--workers", "1", "--quiet"]) == 0
    first = {k: json.loads((out / "units" / f"U{k}.report.json").read_text()) for k in range(3)}

    def no_calibration(*args, **kwargs):
        raise AssertionError("a unit was calibrated again")

    monkeypatch.setattr(B, "calibrate", no_calibration)
    cut = float(sorted(sigma.values())[1]) * 1.000001
    sheet.write_text(f'format = "casadi-sins-tolerance/1"\n[accept.sigma]\ngyro_bias_x = {cut!r}\n')
    assert main(["batch", str(root / "recs"), "--out", str(out), "--tolerance", str(sheet), "--certificate",
                 "--workers", "1", "--quiet"]) == 3
    printed = capsys.readouterr().out
    assert "3 of them judged again against the sheet" in printed
    worst = f"U{max(sigma, key=sigma.get)}"
    fleet = pd.read_csv(out / "fleet.csv", keep_default_na=False).set_index("unit_id")
    assert fleet.loc[worst, "verdict"] == "fail" and "gyro_bias_x: sigma" in fleet.loc[worst, "message"]
    assert all(fleet.loc[u, "message"] for u in fleet.index if fleet.loc[u, "verdict"] == "fail")
    assert "out of tolerance: gyro_bias_x" in (out / "fleet.md").read_text() and "gyro_bias_x: sigma" in printed
    report = json.loads((out / "units" / f"{worst}.report.json").read_text())
    table = out / "units" / f"{worst}.csv"
    import hashlib
    assert report["verdict"] == "fail" and report["table_sha256"] == hashlib.sha256(table.read_bytes()).hexdigest()
    assert report["created"] == first[int(worst[1])]["created"]  # the same calibration, judged again
    assert report["certificate"]["number"] != first[int(worst[1])]["certificate"]["number"]
    page = (out / "units" / f"{worst}.certificate.html").read_text()
    assert "VERDICT: FAIL" in page and page.count("data:image/png;base64,") == 2
    assert dict(pd.read_csv(table, keep_default_na=False)[["parameter", "acceptance"]].values)["gyro_bias_x"] == "fail"


def test_several_setpoints_of_one_unit_show_their_temperature(tmp_path, short_problem, capsys):
    """One unit at two temperatures: the fleet rows differ by a temperature column, on screen and in fleet.md."""
    import dataclasses

    from casadi_sins.data.conditions import Conditions
    from casadi_sins.data.description import recording_files
    from casadi_sins.core.files import write_files

    for k, t in enumerate((-10.0, 40.0)):
        rec = simulate(short_problem, seed=40 + k, name=f"SN9-{k}").recording
        rec = dataclasses.replace(rec, conditions=Conditions(temperature_c=t, unit_id="SN9"))
        write_files(recording_files(rec, tmp_path / "recs" / f"SN9-{k}.toml"))
    assert main(["batch", str(tmp_path / "recs"), "--out", str(tmp_path / "out"), "--workers", "1", "--quiet"]) == 0
    printed = capsys.readouterr().out
    lines = [line for line in printed.splitlines() if line.strip().startswith("SN9")]
    assert "temperature_c" in printed and len(lines) == 2 and lines[0] != lines[1]
    assert "-10" in lines[0] + lines[1] and "40" in lines[0] + lines[1]
    assert "temperature_c" in (tmp_path / "out" / "fleet.md").read_text()
