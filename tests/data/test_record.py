"""A calibration's record (:mod:`casadi_sins.data.record`): the table and its companion report, written and read
in one place."""

import hashlib
import json

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.core.errors import InputError
from casadi_sins.data.record import (REPORT_FORMAT, CalibrationRecord, companion_paths, read_record, read_report,
                                     report_bytes)
from casadi_sins.data.tables import read_table, table_text
from casadi_sins.model import registry as R
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.report.calibration import recording_hash
from casadi_sins.data.description import read_recording
from casadi_sins.sim import simulate, write_simulation

CONDITIONS = '\n[conditions]\ntemperature_c = 31.5\ndate = "2025-06-02"\noperator = "A. Engineer"\nbench = "B2"\n'


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory, short_problem):
    """A table and report written by ``calibrate`` itself (not by hand): a recording with conditions, a unit id and
    a tolerance sheet its gyro biases miss (a verdict with reasons)."""
    tmp = tmp_path_factory.mktemp("record")
    rec = write_simulation(simulate(short_problem, seed=7), tmp / "rec")
    rec.write_text(rec.read_text() + CONDITIONS)
    sheet = tmp / "tight.toml"
    sheet.write_text('format = "casadi-sins-tolerance/1"\n[accept.sigma]\n"gyro bias" = 1e-9\n')
    out = tmp / "P.csv"
    status = main(["calibrate", str(rec), "--out", str(out), "--unit-id", "SN 7", "--tolerance", str(sheet),
                   "--quiet"])
    assert status == 3  # the sheet fails it
    return rec, out


def test_a_report_written_by_calibrate_reads_as_its_record(calibrated):
    rec, table = calibrated
    record = read_record(table)
    data = json.loads(companion_paths(table)[0].read_text())
    params = read_table(table)
    np.testing.assert_array_equal(record.parameters.values, params.values)
    cov = record.covariance
    assert cov is not None and cov.shape == (len(params.names), len(params.names))
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), params.sigma, rtol=1e-12)
    np.testing.assert_array_equal(record.parameters.covariance, np.array(data["covariance"]))
    prov = record.provenance
    digest = hashlib.sha256(table.read_bytes()).hexdigest()
    assert prov.from_report and prov.table_sha256 == digest == record.stored_table_sha256
    assert prov.recording_sha256 == recording_hash(read_recording(rec)) and prov.recording == data["recording"]["name"]
    assert prov.unit_id == record.unit_id == "SN 7" and prov.solver == "nlp"
    assert prov.date.isoformat(timespec="seconds") == data["created"]
    assert record.conditions == {"temperature_c": 31.5, "date": "2025-06-02", "operator": "A. Engineer",
                                 "bench": "B2"}
    assert record.temperature_c == 31.5 and prov.recorded.year == 2025
    assert record.verdict == "fail" and record.reasons and record.reasons == data["acceptance"]["reasons"]
    assert all("gyro_bias" in r for r in record.reasons)
    assert record.warnings == data["warnings"]


def test_a_record_written_again_reads_the_same(calibrated, tmp_path):
    """Round trip: a record read, written beside a copy of its table, read back: every field the same."""
    _, table = calibrated
    record = read_record(table)
    copy = tmp_path / "C.csv"
    copy.write_bytes(table.read_bytes())
    again = record.with_table(copy, hashlib.sha256(copy.read_bytes()).hexdigest())
    companion_paths(copy)[0].write_bytes(again.report_json())
    back = read_record(copy)
    assert back.report == {**record.report, "table": "C.csv"}
    np.testing.assert_array_equal(back.covariance, record.covariance)
    for field in ("unit_id", "conditions", "verdict", "reasons", "warnings", "recording_sha256", "stored_table_sha256"):
        assert getattr(back, field) == getattr(record, field), field
    p, q = back.provenance, record.provenance
    assert (p.date, p.unit_id, p.recording_sha256, p.software, p.versions, p.conditions, p.table_sha256) == \
        (q.date, q.unit_id, q.recording_sha256, q.software, q.versions, q.conditions, q.table_sha256)


def test_a_new_record_round_trips_through_its_files(tmp_path):
    """A record made for writing (:meth:`CalibrationRecord.of_calibration`) reads back bit for bit."""
    rng = np.random.default_rng(3)
    names = R.model_names(("gyro_gsens",))
    size = R.natural_scale_of(names) * np.where(R.relative_mask(names), 1e-6, 1.0)
    values = np.where(R.relative_mask(names), 1.0, 0.0) + size * rng.normal(size=len(names))
    root = rng.normal(size=(len(names), len(names))) * size
    params = ParameterSet(values, covariance=root @ root.T, names=names)
    record = CalibrationRecord.of_calibration(
        params, solver="nlp", unit_id="U1", recording={"name": "r", "sha256": "ab" * 32},
        conditions={"temperature_c": -5.0, "operator": "B"}, warnings=["w1"], details={"message": "m"},
        verdict="pass", acceptance={"reasons": [], "sheet": "s.toml"}, command="casadi-sins calibrate r.toml")
    table = tmp_path / "N.csv"
    text = table_text(params).encode()
    table.write_bytes(text)
    written = record.with_table(table, hashlib.sha256(text).hexdigest())
    companion_paths(table)[0].write_bytes(written.report_json())
    back = read_record(table)
    np.testing.assert_array_equal(back.parameters.values, params.values)
    np.testing.assert_array_equal(back.covariance, params.covariance)
    assert back.report == json.loads(report_bytes(written.report))
    assert back.report["format"] == REPORT_FORMAT and back.report["command"] == "casadi-sins calibrate r.toml"
    assert (back.unit_id, back.verdict, back.reasons, back.warnings) == ("U1", "pass", [], ["w1"])
    assert back.provenance.recording_sha256 == "ab" * 32 and back.provenance.table_sha256 == written.file_sha256
    assert back.temperature_c == -5.0


def test_a_table_without_report_is_a_record_without_covariance(calibrated, tmp_path):
    _, table = calibrated
    bare = tmp_path / "bare.csv"
    bare.write_bytes(table.read_bytes())
    record = read_record(bare)
    assert not record.from_report and record.covariance is None and record.report == {}
    assert record.parameters is record.table_parameters
    prov = record.provenance
    assert not prov.from_report and prov.table_sha256 == hashlib.sha256(bare.read_bytes()).hexdigest()
    assert "no companion report" in prov.metadata()["provenance"]
    assert (record.verdict, record.reasons, record.warnings, record.temperature_c) == (None, [], [], None)


@pytest.mark.parametrize("content,message", [
    (b'{"format": "casadi-sins-report/1", "covar', "not a JSON calibration report"),
    (b"[1, 2]", "a list, not an object"),
    (b"\xff\xfe{}", "not a JSON calibration report"),
    (b"[" * 100_000, "not a JSON calibration report"),
])
def test_a_truncated_or_hostile_report_is_one_input_error_naming_it(calibrated, tmp_path, content, message):
    _, table = calibrated
    copy = tmp_path / "H.csv"
    copy.write_bytes(table.read_bytes())
    report = companion_paths(copy)[0]
    report.write_bytes(content)
    with pytest.raises(InputError, match=message) as exc:
        read_record(copy)
    assert exc.value.path == report


def test_a_report_that_is_no_file_is_refused(calibrated, tmp_path):
    _, table = calibrated
    copy = tmp_path / "D.csv"
    copy.write_bytes(table.read_bytes())
    companion_paths(copy)[0].mkdir()
    with pytest.raises(InputError, match="is a folder"):
        read_report(copy)


def test_a_report_that_is_not_a_calibration_report_has_no_provenance(calibrated, tmp_path):
    """A hand-made report with only a covariance still weighs its table; it dates nothing."""
    _, table = calibrated
    copy = tmp_path / "K.csv"
    copy.write_bytes(table.read_bytes())
    cov = read_record(table).covariance
    companion_paths(copy)[0].write_text(json.dumps({"covariance": cov.tolist()}))
    record = read_record(copy)
    np.testing.assert_array_equal(record.parameters.covariance, cov)
    with pytest.raises(InputError, match="not a casadi-sins calibration report"):
        record.provenance
    companion_paths(copy)[0].write_text(json.dumps({"format": REPORT_FORMAT, "created": "9999-01-01T00:00:00"}))
    with pytest.raises(InputError, match="years 1970 to 2199"):
        read_record(copy).provenance


def test_a_covariance_that_is_not_the_tables_is_refused(calibrated, tmp_path):
    _, table = calibrated
    copy = tmp_path / "M.csv"
    copy.write_bytes(table.read_bytes())
    data = json.loads(companion_paths(table)[0].read_text())
    data["covariance"] = (2.0 * np.array(data["covariance"])).tolist()
    companion_paths(copy)[0].write_text(json.dumps(data))
    with pytest.raises(InputError, match="diagonal does not match the sigma"):
        read_record(copy).parameters


def test_a_report_alone_gives_the_tables_values_and_sigma(calibrated):
    """``batch`` resumes from a unit's report (its ledger) without reading the table: the same values and sigma."""
    _, table = calibrated
    data = json.loads(companion_paths(table)[0].read_text())
    params, alone = read_table(table), CalibrationRecord.of_report(data).parameters
    assert alone.names == params.names
    np.testing.assert_array_equal(alone.values, params.values)
    np.testing.assert_array_equal(alone.sigma, params.sigma)
    data["parameters"] = [{"parameter": "gyro_bias_x", "value": "1"}, 7, {"value": 1.0}] + data["parameters"][:2]
    assert CalibrationRecord.of_report(data).parameters.names == params.names[:2]  # rows that are none are left out
