"""Never lose or endanger a user's data (issue 24): no output over an input, bounded readers, validated
tables, safe text in every output, a batch ledger that cannot be fooled, interrupts that end cleanly."""

import gzip
import hashlib
import json
import os
import signal

import numpy as np
import pandas as pd
import pytest

import casadi_sins.cli as cli
from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.cli import main
from casadi_sins.core import signals
from casadi_sins.core.errors import InputError
from casadi_sins.core.files import gathered_writes, safe_stem, write_files
from casadi_sins.core.text import decimal_number, spreadsheet_cell
from casadi_sins.core.toml import read_toml
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.data.tables import read_table, write_table
from casadi_sins.model import registry as R
from casadi_sins.report.cheader import c_header
from casadi_sins.sim import simulate
from casadi_sins.studies import batch


@pytest.fixture()
def recording(short_problem, tmp_path):
    return write_recording(simulate(short_problem, seed=4).recording, tmp_path / "rec" / "r.toml")


@pytest.fixture()
def table(recording):
    return write_table(recording.parent / "p.csv", rough_parameters(read_recording(recording)))


def refused(capsys, *needles):
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    for needle in needles:
        assert needle in err, (needle, err)


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_calibrating_onto_the_recordings_own_csv_is_refused_and_the_csv_kept(recording, capsys):
    """The README flow with one stem: segment unit42.csv --out unit42.toml; calibrate unit42.toml --out unit42.csv."""
    csv = recording.with_suffix(".csv")
    before = digest(csv)
    assert main(["calibrate", str(recording), "--out", str(csv)]) == 2
    refused(capsys, "r.csv", "input of this command")
    assert digest(csv) == before
    os.link(csv, recording.parent / "hard.csv")  # the same file by another name
    assert main(["calibrate", str(recording), "--out", str(recording.parent / "hard.csv")]) == 2
    refused(capsys, "hard.csv", "input")
    assert digest(csv) == before


def test_rough_and_export_onto_their_input_are_refused(recording, table, capsys):
    toml = recording.read_bytes()
    assert main(["rough", str(recording), "--out", str(recording)]) == 2
    refused(capsys, "r.toml", "input")
    assert recording.read_bytes() == toml
    before = table.read_bytes()
    for fmt in ("json", "c", "psins"):
        assert main(["export", str(table), "--format", fmt, "--out", str(table)]) == 2
        refused(capsys, "p.csv", "input")
    assert table.read_bytes() == before


def test_an_output_that_is_a_device_or_a_link_to_one_is_refused(table, tmp_path, capsys):
    link = tmp_path / "null.json"
    link.symlink_to(os.devnull)
    assert main(["export", str(table), "--format", "json", "--out", str(link)]) == 2
    refused(capsys, "null.json", "not a regular file")
    assert link.is_symlink() and os.readlink(link) == os.devnull
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    assert main(["export", str(table), "--format", "json", "--out", str(fifo)]) == 2
    refused(capsys, "fifo.json", "not a regular file")


@pytest.mark.parametrize("name", ["../../x", "/tmp/casadi-sins-escape", "..\\..\\y", ".hidden", "١٢٣"])
def test_a_path_like_name_stays_inside_the_output_folder(name):
    stem = safe_stem(name)
    assert "/" not in stem and "\\" not in stem and not stem.startswith(".") and stem.isascii() and stem


def test_analyze_with_a_path_like_name_writes_only_inside_out(recording, tmp_path):
    text = recording.read_text().replace('name = "', 'name = "../../escaped', 1)
    recording.write_text(text)
    out = tmp_path / "deep" / "out"
    assert main(["analyze", str(recording), "--out", str(out)]) == 0
    written = {p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file()}
    outside = [p for p in written if not str(p).startswith(("deep/out/", "rec/"))]
    assert outside == [] and any(out.glob("escaped*-predicted.csv"))


def test_a_failing_command_leaves_nothing_staged(tmp_path):
    with pytest.raises(RuntimeError), gathered_writes():
        write_files({tmp_path / "a" / "x.csv": b"1"})
        write_files({tmp_path / "b.md": b"2"})
        raise RuntimeError("full disk")
    assert list(tmp_path.rglob("*")) == []
    with gathered_writes():
        write_files({tmp_path / "a" / "x.csv": b"1"})
        assert not (tmp_path / "a").exists()  # staged only
    assert (tmp_path / "a" / "x.csv").read_bytes() == b"1"


@pytest.mark.parametrize("power", [160, 300])
def test_a_huge_finite_column_is_refused_at_once(recording, power):
    csv = recording.with_suffix(".csv")
    frame = pd.read_csv(csv)
    frame["gyro_x"] = frame["gyro_x"] * 10.0**power + 10.0**power
    frame.to_csv(csv, index=False)
    with pytest.raises(InputError, match=r"r\.csv, line 2, column gyro_x: .* not a physical measurement"):
        read_recording(recording)


def test_a_gzip_bomb_stops_at_its_first_bad_line(recording):
    csv = recording.with_suffix(".csv")
    header, first = csv.read_text().splitlines()[:2]
    bomb = csv.with_suffix(".csv.gz")
    with gzip.open(bomb, "wb", compresslevel=1) as handle:
        handle.write(f"{header}\n".encode() + f"{first}\n".encode() * 400_000)  # one instant repeated
    recording.write_text(recording.read_text().replace('r.csv"', 'r.csv.gz"'))
    with pytest.raises(InputError, match=r"r\.csv\.gz, line 3: time .* does not increase"):
        read_recording(recording)
    with gzip.open(bomb, "wb", compresslevel=1) as handle:
        handle.write(f"{header}\n{first}\n".encode() + b"0" * (3 << 20))  # a line without end
    with pytest.raises(InputError, match=r"line 3: a line longer than"):
        read_recording(recording)


@pytest.mark.parametrize("cell", ["١٢٣", "１２３", "1_000", "0x10"])
def test_only_ascii_decimal_numbers_are_read(recording, cell):
    csv = recording.with_suffix(".csv")
    lines = csv.read_text().splitlines()
    cells = lines[4].split(",")
    cells[4] = cell
    lines[4] = ",".join(cells)
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"line 5, column .*not a finite number"):
        read_recording(recording)
    with pytest.raises(ValueError):
        decimal_number(cell)


def test_tables_and_toml_refuse_digit_groups(table, recording):
    table.write_text(table.read_text().replace("accel_bias_x,m/s^2,0.0", "accel_bias_x,m/s^2,1_0"))
    with pytest.raises(InputError, match="line 2: value '1_0'"):
        read_table(table)
    recording.write_text(recording.read_text().replace("rate_hz = 100.0", "rate_hz = 1_00"))
    with pytest.raises(InputError, match="not a plain decimal number"):
        read_toml(recording, "recording description")


def singular(table):
    text = table.read_text()
    for name in ("gyro_misalign_xy", "gyro_misalign_yx"):
        text = text.replace(f"{name},rad,0.0", f"{name},rad,1.0")
    table.write_text(text)
    return table


def test_a_singular_table_is_refused_by_export_and_apply(table, recording, tmp_path, capsys):
    singular(table)
    for fmt in ("c", "json", "psins", "yaml"):
        assert main(["export", str(table), "--format", fmt, "--out", str(tmp_path / f"x.{fmt}")]) == 2
        refused(capsys, "p.csv", "singular")
    assert main(["apply", str(table), str(recording), "--out", str(tmp_path / "applied")]) == 2
    refused(capsys, "singular")
    assert not (tmp_path / "applied").exists() and not list(tmp_path.glob("x.*"))


def test_a_zero_or_huge_scale_and_a_huge_bias_are_refused(table):
    text = table.read_text()
    for old, new in (("gyro_scale_x,rad/pulse,", "gyro_scale_x,rad/pulse,0#"),
                     ("accel_bias_y,m/s^2,0.0", "accel_bias_y,m/s^2,1e300")):
        line = next(l for l in text.splitlines() if l.startswith(old.split("#")[0].split(",")[0] + ","))
        cells = line.split(",")
        cells[2] = "0" if "scale" in old else "1e300"
        table.write_text(text.replace(line, ",".join(cells)))
        with pytest.raises(InputError, match=cells[0]):
            read_table(table)


def test_no_fleet_cell_is_a_spreadsheet_formula(tmp_path):
    ids = ["=cmd|' /C calc'!A0", "+1", "@SUM(A1)", "-2", "SN 1"]
    fleet = pd.DataFrame({"unit_id": ids, "recording": [f"={i}.toml" for i in range(5)], "status": "ok",
                          "warnings": 0, "message": ["=HYPERLINK(x)"] * 5})
    spread = pd.DataFrame([{c: float("nan") for c in batch.SPREAD_COLUMNS}])
    spread[["parameter", "unit", "outliers"]] = ["accel_bias_x", "ug", " ".join(ids)]
    files = batch.batch_files(fleet, spread, tmp_path)
    for path, data in files.items():
        if path.suffix == ".csv":
            frame = pd.read_csv(pd.io.common.BytesIO(data), dtype=str, keep_default_na=False)
            cells = [str(c) for c in frame.to_numpy().ravel()]
            assert not any(c.startswith(("=", "+", "@")) for c in cells), cells
    assert spreadsheet_cell("plain") == "plain"


def test_outlier_ids_with_spaces_stay_whole():
    fleet = pd.DataFrame({"unit_id": ["SN 1", "SN2"], "recording": ["a", "b"], "status": ["ok", "ok"],
                          "warnings": [0, 0], "message": ["", ""]})
    spread = pd.DataFrame({"parameter": ["accel_bias_x"], "outliers": ["'SN 1'"]})
    out = batch.with_outliers(fleet, spread)
    assert list(out["outliers"]) == ["accel_bias_x", ""]


def test_duplicate_unit_ids_are_refused_naming_both(recording, tmp_path):
    twin = tmp_path / "twin.toml"
    twin.write_text(recording.read_text().replace('data = "', 'data = "rec/', 1))
    with pytest.raises(InputError, match=r"twin\.toml: unit id 'short-seed4' is also that of .*r\.toml"):
        batch.check_unit_ids([recording, twin])


def test_resume_recomputes_a_unit_whose_stored_table_changed(recording, table, tmp_path):
    out = tmp_path / "out"
    unit = batch.unit_table_path(out, recording)
    unit.parent.mkdir(parents=True)
    unit.write_bytes(table.read_bytes())
    report = unit.with_name(unit.stem + ".report.json")
    data = {"recording": {"sha256": batch.file_hash(recording)}, batch.LEDGER_TABLE_KEY: digest(unit)}
    report.write_text(json.dumps(data))
    assert batch.finished(recording, out) == data
    unit.write_text("garbage\n")
    assert batch.finished(recording, out) is None


def test_c_header_guards_differ_and_comments_cannot_close():
    params = read_table_like()
    a, b = (c_header(params, {"unit_id": u}) for u in ("SN-1", "SN_1"))
    guard = [line for line in a.splitlines() if line.startswith("#define CASADI_SINS_COMPENSATION")]
    assert guard and guard[0] not in b
    text = c_header(params, {"unit_id": "x */ int evil; /* y"})
    body = text.split("*/", 1)[1]
    assert "int evil" not in body.split("#ifndef")[0] and text.count("/*") == text.count("*/")


def read_table_like():
    from casadi_sins.model.parameters import ParameterSet

    p = np.zeros(R.N_PARAMS)
    p[R.ACCEL_SCALE], p[R.GYRO_SCALE] = 3.5e-4, 1e-7
    return ParameterSet(p)


def test_a_signal_turned_into_another_error_is_still_an_interruption(monkeypatch, capsys):
    monkeypatch.setattr(signals, "_received", signal.SIGINT)
    assert cli._outcome("casadi-sins x", RuntimeError("Error in Function::call for 'solver' [IpoptInterface]")) == 130
    monkeypatch.setattr(signals, "_received", signal.SIGTERM)
    assert cli._outcome("casadi-sins x", RuntimeError("x")) == 143
    monkeypatch.setattr(signals, "_received", 0)
    assert cli._outcome("casadi-sins x", InputError("f", "bad")) == 2


def test_small_hand_cases_are_one_line_exit_2(recording, table, tmp_path, capsys):
    report = table.with_name("p.report.json")
    report.write_text(json.dumps({"format": "casadi-sins-report/1", "created": "9999-12-31T23:59:59+14:00"}))
    second = table.with_name("q.csv")
    second.write_bytes(table.read_bytes())
    assert main(["history", str(table), str(second), "--out", str(tmp_path / "h")]) == 2
    refused(capsys, "not a date of a calibration")
    assert main(["batch", str(recording), "--dask", "not a url", "--out", str(tmp_path / "b")]) == 2
    refused(capsys, "--dask")
    csv = recording.with_suffix(".csv")
    assert main(["segment", str(csv), "--rate", "100", "--latitude", "37", "--name", "a\nb",
                 "--out", str(tmp_path / "s.toml")]) == 2
    refused(capsys, "--name")
    assert not (tmp_path / "s.toml").exists()


def test_two_writers_making_the_same_folders_both_succeed(tmp_path, monkeypatch):
    """The folder made by another process between our look and our mkdir is no failure."""
    import pathlib

    real_mkdir = pathlib.Path.mkdir

    def racing_mkdir(self, *args, **kwargs):
        real_mkdir(self, *args, **kwargs)  # the other process wins the race ...
        raise FileExistsError(17, "File exists", str(self))  # ... and ours finds it made

    monkeypatch.setattr(pathlib.Path, "mkdir", racing_mkdir)
    write_files({tmp_path / "a" / "b" / "x.csv": b"1"})
    assert (tmp_path / "a" / "b" / "x.csv").read_bytes() == b"1"
