"""Bad input and bad output locations: one line naming the place, exit status 2, nothing half-written
(issue 11's fuzz classes)."""

import gzip
import shutil
import subprocess
import sys

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.core.errors import InputError
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.sim import simulate


@pytest.fixture()
def recording(short_problem, tmp_path):
    return write_recording(simulate(short_problem, seed=4).recording, tmp_path / "rec" / "r.toml")


def one_line_error(capsys, *needles):
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    for needle in needles:
        assert needle in err, (needle, err)
    return err


def edit(path, old, new):
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


def test_folders_in_place_of_files_are_named(recording, tmp_path, capsys):
    assert main(["validate", str(recording.parent)]) == 2
    one_line_error(capsys, "is a folder")
    edit(recording, 'data = "r.csv"', 'data = "."')
    assert main(["validate", str(recording)]) == 2
    one_line_error(capsys, "is a folder", "'data' must name")
    edit(recording, 'data = "."', 'data = ""')
    assert main(["validate", str(recording)]) == 2
    one_line_error(capsys, "'data' is empty")


def test_output_locations_are_checked_before_any_computation(recording, tmp_path, capsys):
    (tmp_path / "plain-file").write_text("x")
    for args in (["calibrate", str(recording), "--out", str(tmp_path)],
                 ["calibrate", str(recording), "--out", str(tmp_path / "plain-file" / "p.csv")],
                 ["navigate", str(recording), "--out", str(tmp_path / "plain-file")],
                 ["calibrate", str(recording), "--out", str(tmp_path / "ok.csv"), "--report",
                  str(tmp_path / "plain-file")]):
        assert main(args) == 2
        one_line_error(capsys, "plain-file" if "plain-file" in " ".join(args) else "is a folder")
    assert not (tmp_path / "ok.csv").exists() and not list(tmp_path.glob(".*tmp"))


def test_a_site_off_the_ground_is_rejected(recording, capsys):
    edit(recording, "height_m = 0.0", "height_m = 10000000.0")
    with pytest.raises(InputError, match=r"height_m 1e\+07 is outside -500..10000 m"):
        read_recording(recording)


@pytest.mark.parametrize("value", ["1e300", "-5.28e16"])
def test_a_sample_beyond_any_physical_value_is_rejected_naming_the_line(recording, value):
    csv = recording.with_suffix(".csv")
    lines = csv.read_text().splitlines()
    cells = lines[40].split(",")
    cells[5] = value
    lines[40] = ",".join(cells)
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"r\.csv, line 41, column accel_y: .* not a physical measurement"):
        read_recording(recording)


def test_invalid_utf8_names_the_line(recording):
    toml = recording.read_bytes().replace(b'name = "', b'name = "\xff', 1)
    recording.write_bytes(toml)
    line = toml[: toml.index(b"\xff")].count(b"\n") + 1
    with pytest.raises(InputError, match=rf"r\.toml, line {line}: not UTF-8"):
        read_recording(recording)
    recording.write_bytes(toml.replace(b'name = "\xff', b'name = "', 1))
    csv = recording.with_suffix(".csv")
    data = csv.read_bytes().split(b"\n")
    data[7] = data[7] + b"\xfe"
    csv.write_bytes(b"\n".join(data))
    with pytest.raises(InputError, match=r"r\.csv, line 8: not UTF-8"):
        read_recording(recording)


def test_a_name_with_folders_cannot_write_outside_out(recording, tmp_path):
    edit(recording, 'name = "short-seed4"', 'name = "../../escape"')
    out = tmp_path / "nav"
    assert main(["navigate", str(recording), "--out", str(out)]) == 0
    written = {p.name for p in out.iterdir()}
    assert "escape-velocity.png" in written and not (tmp_path / "escape-velocity.png").exists()


def test_analyze_with_a_missing_file_or_a_csv_gives_one_line(recording, tmp_path, capsys):
    assert main(["analyze", str(tmp_path / "missing.toml"), "--out", str(tmp_path / "a")]) == 2
    one_line_error(capsys, "missing.toml", "no such problem file")
    assert main(["analyze", str(recording.with_suffix(".csv")), "--out", str(tmp_path / "a")]) == 2
    one_line_error(capsys, "r.csv", "not valid TOML for a problem file")


def test_compressed_data_are_read(recording):
    csv = recording.with_suffix(".csv")
    with open(csv, "rb") as src, gzip.open(csv.with_suffix(".csv.gz"), "wb") as dst:
        shutil.copyfileobj(src, dst)
    plain = read_recording(recording)
    edit(recording, 'data = "r.csv"', 'data = "r.csv.gz"')
    np.testing.assert_array_equal(read_recording(recording).accel, plain.accel)


def test_python_dash_m_runs_the_command_line():
    done = subprocess.run([sys.executable, "-m", "casadi_sins", "--version"], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.startswith("casadi-sins ")


def test_a_reader_that_leaves_early_loses_no_output(recording, tmp_path):
    """``casadi-sins calibrate ... | head -1``: the summary's reader goes away after a line; the table is still
    written whole and the command ends normally (every output is written together, so a broken pipe must not
    abandon them)."""
    table = tmp_path / "t.csv"
    script = "import sys; from casadi_sins.cli import main; sys.exit(main(sys.argv[1:]))"
    proc = subprocess.Popen([sys.executable, "-c", script, "calibrate", str(recording), "--quiet", "--out", str(table)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone before the first line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 0, err
    assert "Traceback" not in err and "Broken pipe" not in err
    assert len(table.read_text().splitlines()) > 21
