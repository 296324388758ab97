"""Recording conditions: the ``[conditions]`` table and the ``temperature`` column, read, validated, written
back, carried into the report and the provenance of the table."""

import dataclasses
import datetime
import json

import numpy as np
import pytest

from casadi_sins.core.errors import InputError
from casadi_sins.data.conditions import Conditions, parse_conditions, parse_date, recording_temperature_c
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.sim import simulate


@pytest.fixture(scope="module")
def short_rec(short_problem):
    return simulate(short_problem, seed=3).recording


def test_dates_are_validated_and_normalised():
    table = {"date": "2024-05-17T09:30:00Z", "temperature_c": 23, "operator": " A. Engineer ", "bench": 2}
    cond, notes = parse_conditions(table, "r.toml")
    assert cond == Conditions(23.0, "2024-05-17T09:30:00+00:00", "A. Engineer", "2", None) and notes == []
    assert parse_conditions({"date": datetime.date(2024, 5, 17)}, "r.toml")[0].date == "2024-05-17"
    assert parse_date("2024-05-17") == datetime.datetime(2024, 5, 17, tzinfo=datetime.timezone.utc)
    assert cond.to_dict() == {"temperature_c": 23.0, "date": "2024-05-17T09:30:00+00:00", "operator": "A. Engineer",
                              "bench": "2"}


@pytest.mark.parametrize("table, key", [({"date": "17/05/2024"}, "date"), ({"temperature_c": 300.0}, "temperature_c"),
                                        ({"temperature_c": "warm"}, "temperature_c"), ({"operator": "a\nb"}, "operator")])
def test_bad_conditions_are_one_line_naming_file_and_key(table, key):
    with pytest.raises(InputError) as err:
        parse_conditions(table, "r.toml")
    text = str(err.value)
    assert "r.toml" in text and f"[conditions] {key}" in text and "\n" not in text


def test_unknown_keys_are_a_warning_not_an_error():
    cond, notes = parse_conditions({"temprature_c": 20.0}, "r.toml")
    assert not cond and len(notes) == 1 and "temprature_c" in notes[0]


def test_conditions_and_temperature_column_round_trip(short_rec, tmp_path):
    n = len(short_rec.time)
    temperature = 20.0 + np.linspace(0.0, 2.0, n)
    rec = dataclasses.replace(short_rec, conditions=Conditions(date="2024-05-17", unit_id="SN-1"),
                              temperature=temperature)
    back = read_recording(write_recording(rec, tmp_path / "c.toml"))
    assert back.conditions == rec.conditions
    np.testing.assert_array_equal(back.temperature, temperature)
    statics = np.concatenate([temperature[rec.segment_samples(s)] for s in rec.static_segments])
    assert recording_temperature_c(back) == pytest.approx(statics.mean(), rel=1e-12)
    assert recording_temperature_c(dataclasses.replace(back, conditions=Conditions(temperature_c=5.0))) == 5.0


def test_temperature_column_out_of_range_names_the_line(short_rec, tmp_path):
    temperature = np.full(len(short_rec.time), 21.0)
    temperature[4] = 294.0  # Kelvin
    path = write_recording(dataclasses.replace(short_rec, temperature=temperature), tmp_path / "k.toml")
    with pytest.raises(InputError, match=r"line 6.*temperature 294"):
        read_recording(path)


def test_conditions_reach_report_and_provenance(short_rec, tmp_path):
    from casadi_sins.calibrate import calibrate_nlp
    from casadi_sins.core.files import write_files
    from casadi_sins.data.tables import table_text
    from casadi_sins.report.calibration import report_files
    from casadi_sins.report.provenance import read_provenance

    rec = dataclasses.replace(short_rec, conditions=Conditions(temperature_c=31.5, date="2023-01-02", bench="B7"))
    result = calibrate_nlp(rec)
    table = tmp_path / "t.csv"
    write_files({table: table_text(result.parameters).encode(), **report_files(result, rec, table)})
    data = json.loads((tmp_path / "t.report.json").read_text())
    assert data["conditions"] == {"temperature_c": 31.5, "date": "2023-01-02", "bench": "B7"}
    assert "## Conditions" in (tmp_path / "t.report.md").read_text()
    prov = read_provenance(table)
    assert prov.conditions["temperature_c"] == 31.5 and prov.recorded.year == 2023
    assert prov.metadata()["recording_date"] == "2023-01-02"


def _calibration(created: str, recorded: str | None, scale_ppm: float):
    from casadi_sins.model import registry as R
    from casadi_sins.model.parameters import ParameterSet
    from casadi_sins.report.provenance import Provenance
    from casadi_sins.studies.history import Calibration

    base = np.zeros(21)
    base[R.SCALE_MASK] = 1e-6
    base[R.GYRO_SCALE.start] *= 1 + scale_ppm * 1e-6
    params = ParameterSet(base, sigma=np.full(21, 1e-9) * np.where(R.SCALE_MASK, 1e-6, 1.0))
    conditions = {"date": recorded} if recorded else {}
    prov = Provenance(table=__import__("pathlib").Path(f"{created}.csv"), table_sha256="0" * 64,
                      date=datetime.datetime.fromisoformat(created), from_report=True, conditions=conditions)
    return Calibration(prov, params)


def test_history_orders_by_recording_date_and_gives_no_drift_over_a_short_span():
    from casadi_sins.studies.history import changes_frame, drift_rates, summary_frame

    # calibrated in the opposite order of their recording, a year apart by recording date
    cals = [_calibration("2025-06-01T00:00:00+00:00", "2025-01-01", 10.0),
            _calibration("2025-06-02T00:00:00+00:00", "2024-01-01", 0.0)]
    cals.sort(key=lambda c: c.date)
    assert [c.date.year for c in cals] == [2024, 2025] and cals[0].date_from == "recording"
    rate = drift_rates(cals)[0]
    assert np.isfinite(rate).all()
    # 31 s apart: a drift per year would be noise extrapolated a million times: n/a
    close = [_calibration("2025-06-01T00:00:00+00:00", None, 0.0), _calibration("2025-06-01T00:00:31+00:00", None, 10.0)]
    assert np.isnan(drift_rates(close)[0]).all()
    summary = summary_frame(close, changes_frame(close))
    assert summary["drift_per_year"].isna().all() and summary["z_first_to_last"].notna().all()


def test_a_rest_refusal_names_the_option_that_lifts_it(short_problem, tmp_path, capsys):
    """The refusal of a short rest suggests --min-rest-s; following its advice calibrates."""
    import re

    from casadi_sins.cli import main

    path = write_recording(simulate(short_problem, seed=4).recording, tmp_path / "s.toml")
    assert main(["calibrate", str(path), "--out", str(tmp_path / "a.csv"), "--min-rest-s", "30"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "at rest for only" in err
    advice = re.search(r"--min-rest-s ([0-9.]+)", err).group(1)
    assert main(["calibrate", str(path), "--out", str(tmp_path / "b.csv"), "--min-rest-s", advice]) == 0
    checks = json.loads((tmp_path / "b.report.json").read_text())["checks"]
    assert any(c["name"] == "shortest rest" and c["passed"] and "as stated" in c["detail"] for c in checks)


def test_conditions_reach_the_exports_of_calibrate(short_rec, tmp_path):
    from casadi_sins.cli import main

    rec = dataclasses.replace(short_rec, conditions=Conditions(temperature_c=-5.0, date="2022-12-24", operator="Q"))
    path = write_recording(rec, tmp_path / "c.toml")
    assert main(["calibrate", str(path), "--out", str(tmp_path / "t.csv"), "--export", "json", "psins"]) == 0
    exported = json.loads((tmp_path / "t.compensation.json").read_text())["metadata"]
    assert exported["temperature_c"] == -5.0 and exported["recording_date"] == "2022-12-24" and exported["operator"] == "Q"
    assert "recording_date: 2022-12-24" in (tmp_path / "t.clbt.m").read_text()


def test_the_fleet_table_carries_the_conditions():
    from casadi_sins.studies.batch import row_from_report

    data = {"unit_id": None, "warnings": [], "parameters": [],
            "conditions": {"date": "2024-02-03", "temperature_c": 22.5, "unit_id": "SN-7", "bench": "T2"}}
    row = row_from_report(data, "runs/u7.toml", "ok")
    assert row["unit_id"] == "SN-7" and row["recorded"] == "2024-02-03" and row["temperature_c"] == 22.5
    assert row["bench"] == "T2"
