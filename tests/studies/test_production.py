"""The production line end to end on simulated units: a batch of 20 (2 corrupt recordings, 1 outlier),
then one unit recalibrated after a step in a scale factor and followed by ``history``."""

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from casadi_sins.cli import main
from casadi_sins.core.units import ARCSEC, DEG_PER_H, UG
from casadi_sins.model import registry as R
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.sim import simulate, write_simulation

UNITS = 20
STEP_PPM = 10.0  # gyro_scale_x of unit SN000 after its first calibration (sigma ~0.6 ppm each)


def unit_problem(problem, k: int, step_ppm: float = 0.0):
    """Unit ``SN{k:03d}``: the paper's truth moved by a unit-to-unit spread (seeded by k)."""
    rng = np.random.default_rng(1000 + k)
    truth = problem.truth.values.copy()
    truth[R.SCALE_MASK] *= 1 + rng.normal(0, 100e-6, 6)
    truth[R.ACCEL_BIAS] += rng.normal(0, 50 * UG, 3)
    truth[R.GYRO_BIAS] += rng.normal(0, 0.01 * DEG_PER_H, 3)
    truth[R.ACCEL_MISALIGN] += rng.normal(0, 20 * ARCSEC, 3)
    truth[R.GYRO_MISALIGN] += rng.normal(0, 20 * ARCSEC, 6)
    if k == 17:
        truth[R.ACCEL_BIAS.start] += 5000 * UG  # an outlier of the fleet: 100 x the spread
    truth[R.GYRO_SCALE.start] *= 1 + step_ppm * 1e-6
    return dataclasses.replace(problem, truth=ParameterSet(truth))


def set_date(report_path, date: str):
    data = json.loads(report_path.read_text())
    data["created"] = date
    report_path.write_text(json.dumps(data))


@pytest.fixture(scope="module")
def fleet(tmp_path_factory, short_problem):
    """Twenty recordings, two of them corrupt, calibrated by ``batch`` with two local workers."""
    root = tmp_path_factory.mktemp("line")
    paths = []
    for k in range(UNITS):
        paths.append(write_simulation(simulate(unit_problem(short_problem, k), seed=k, name=f"SN{k:03d}"),
                                      root / "recordings"))
    csv = paths[5].with_suffix(".csv")
    lines = csv.read_text().splitlines()
    lines[300] = lines[300].replace(",", ",abc,", 1).replace(",abc,", ",abc", 1)  # a value that is no number
    csv.write_text("\n".join(lines) + "\n")
    csv = paths[11].with_suffix(".csv")
    csv.write_text("\n".join(csv.read_text().splitlines()[:2000]) + "\n")  # a truncated recording
    out = root / "batch"
    status = main(["batch", *map(str, paths), "--out", str(out), "--workers", "2"])
    return root, paths, out, status


def test_the_batch_finishes_and_reports_the_corrupt_recordings(fleet):
    _, paths, out, status = fleet
    assert status == 2  # some unit failed: non-zero, the others still done
    table = pd.read_csv(out / "fleet.csv", keep_default_na=False)
    assert len(table) == UNITS
    failed = table[table["status"] == "failed"]
    assert sorted(failed["unit_id"]) == ["SN005", "SN011"]
    assert "SN005.csv" in failed.set_index("unit_id").loc["SN005", "message"]
    assert (table[table["status"] != "failed"]["gyro_scale_x_sigma"].astype(float) > 0).all()
    for k in range(UNITS):
        exists = (out / "units" / f"SN{k:03d}.csv").exists() and (out / "units" / f"SN{k:03d}.report.json").exists()
        assert exists == (k not in (5, 11))
    assert "SN005" in (out / "fleet.md").read_text()


def test_the_fleet_spread_flags_the_outlier_unit_and_no_other(fleet):
    _, _, out, _ = fleet
    spread = pd.read_csv(out / "fleet-spread.csv", keep_default_na=False).set_index("parameter")
    assert spread.loc["accel_bias_x", "outliers"] == "SN017"
    assert (spread.drop(index="accel_bias_x")["outliers"] == "").all()
    assert spread.loc["accel_bias_x", "units"] == UNITS - 2


def test_the_batch_resumes_without_recomputing_finished_units(fleet, capsys):
    _, paths, out, _ = fleet
    before = (out / "units" / "SN000.report.json").read_bytes()
    assert main(["batch", *map(str, paths), "--out", str(out), "--workers", "1"]) == 2
    table = pd.read_csv(out / "fleet.csv", keep_default_na=False)
    assert table["resumed"].astype(str).eq("True").sum() == UNITS - 2  # the corrupt ones are tried again
    assert (out / "units" / "SN000.report.json").read_bytes() == before
    assert "18 already done" in capsys.readouterr().out


def test_history_flags_the_step_in_one_scale_factor_and_nothing_else(fleet, short_problem, tmp_path):
    _, _, out, _ = fleet
    later = write_simulation(simulate(unit_problem(short_problem, 0, STEP_PPM), seed=500, name="SN000"),
                             tmp_path / "recal")
    second = tmp_path / "SN000-2025.csv"
    assert main(["calibrate", str(later), "--out", str(second), "--unit-id", "SN000"]) == 0
    first = out / "units" / "SN000.csv"
    set_date(out / "units" / "SN000.report.json", "2024-01-10T09:00:00+00:00")
    set_date(tmp_path / "SN000-2025.report.json", "2025-01-09T15:00:00+00:00")
    sheet = tmp_path / "sheet.toml"
    sheet.write_text('format = "casadi-sins-tolerance/1"\n[change]\n"gyro scale" = 5.0\n"accel bias" = 100.0\n'
                     '[drift_per_year]\ngyro_bias_x = 0.5\n')
    assert main(["history", str(second), str(first), "--tolerance", str(sheet), "--out", str(tmp_path / "h")]) == 0
    summary = pd.read_csv(tmp_path / "h" / "history-summary.csv").set_index("parameter")
    z = summary["z_first_to_last"].abs()
    assert z["gyro_scale_x"] > 4 and z.drop(index="gyro_scale_x").max() < 4
    assert list(summary.index[summary["flagged"]]) == ["gyro_scale_x"]
    assert summary.loc["gyro_scale_x", "change_first_to_last"] == pytest.approx(STEP_PPM, abs=4)
    assert summary.loc["gyro_scale_x", "drift_per_year"] == pytest.approx(STEP_PPM, abs=4)  # one year apart
    assert summary.loc["gyro_scale_x", "status"] == "fail"
    assert summary.loc["accel_bias_x", "status"] == "pass" and summary.loc["gyro_bias_y", "status"] == "no tolerance"
    calibrations = pd.read_csv(tmp_path / "h" / "history-calibrations.csv")
    assert list(calibrations["table"]) == [str(first), str(second)]  # by date, not by argument order
    assert (calibrations["unit_id"] == "SN000").all() and calibrations["recording_sha256"].str.len().eq(64).all()
    assert (tmp_path / "h" / "history-gyro-scale.png").exists()


def test_history_refuses_tables_of_two_units(fleet, tmp_path, capsys):
    _, _, out, _ = fleet
    assert main(["history", str(out / "units" / "SN001.csv"), str(out / "units" / "SN002.csv"),
                 "--out", str(tmp_path / "h")]) == 2
    err = capsys.readouterr().err.strip()
    assert "history follows one unit" in err and len(err.splitlines()) == 1


def test_a_bad_tolerance_sheet_is_named_with_its_line(fleet, tmp_path, capsys):
    _, _, out, _ = fleet
    sheet = tmp_path / "sheet.toml"
    sheet.write_text('[change]\n"gyro scale" = 5.0\ngyro_scael_x = 1.0\n')
    table = str(out / "units" / "SN001.csv")
    assert main(["history", table, table, "--tolerance", str(sheet), "--out", str(tmp_path / "h")]) == 2
    assert "sheet.toml, line 3" in capsys.readouterr().err
