import re
import shutil

import numpy as np
import pytest

from casadi_sins.core.errors import InputError
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.sim import simulate


@pytest.fixture(scope="module")
def written(short_problem, tmp_path_factory):
    sim = simulate(short_problem, seed=2)
    folder = tmp_path_factory.mktemp("rec")
    return sim, write_recording(sim.recording, folder / "short.toml")


def test_round_trip_is_exact(written):
    sim, path = written
    back = read_recording(path)
    rec = sim.recording
    np.testing.assert_array_equal(back.gyro, rec.gyro)
    np.testing.assert_array_equal(back.accel, rec.accel)
    np.testing.assert_allclose(back.time, rec.time, rtol=0, atol=1e-12)
    assert [(s.group, s.kind, s.orientation, s.axis, s.angle_deg, s.start, s.end) for s in back.segments] == \
           [(s.group, s.kind, s.orientation, s.axis, s.angle_deg, s.start, s.end) for s in rec.segments]
    assert back.site.latitude == pytest.approx(rec.site.latitude, rel=1e-15)
    assert back.rate_hz == rec.rate_hz


def test_integer_pulses_are_written_as_integers(short_problem, tmp_path):
    sim = simulate(short_problem.with_changes(quantize=True), seed=1)
    path = write_recording(sim.recording, tmp_path / "q.toml")
    second_line = path.with_suffix(".csv").read_text().splitlines()[1]
    assert all(re.fullmatch(r"-?\d+", x) for x in second_line.split(",")[1:])
    np.testing.assert_array_equal(read_recording(path).gyro, sim.recording.gyro)


def test_peer_recording_reads_and_validates(peer_recording):
    rec = peer_recording
    assert len(rec.time) == 98200 and len(rec.segments) == 37 and rec.group_ids == [1]
    assert rec.site.g == 9.796493808  # the gravity the recording states is used, not normal gravity
    assert rec.segment_samples(rec.segments[0]) == slice(0, 6799)


def copy_recording(path, tmp_path):
    target = tmp_path / "r.toml"
    shutil.copy(path, target)
    shutil.copy(path.with_suffix(".csv"), tmp_path / "r.csv")
    text = target.read_text().replace('data = "short.csv"', 'data = "r.csv"')
    target.write_text(text)
    return target


def edit_csv(path, fn):
    csv = path.with_suffix(".csv")
    lines = csv.read_text().splitlines()
    csv.write_text("\n".join(fn(lines)) + "\n")


def edit_toml(path, old, new, count=1):
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, count))


CSV_CASES = {
    "missing column": (lambda ls: [ls[0].replace(",accel_z", ",accel_q")] + ls[1:],
                       r"r\.csv, line 1: missing column\(s\) accel_z"),
    "NaN": (lambda ls: ls[:5] + [re.sub(r",[^,]*$", ",nan", ls[5])] + ls[6:],
            r"r\.csv, line 6, column accel_z: 'nan' is not a finite number"),
    "infinity": (lambda ls: ls[:7] + [ls[7].split(",")[0] + ",inf," + ",".join(ls[7].split(",")[2:])] + ls[8:],
                 r"r\.csv, line 8, column gyro_x: 'inf' is not a finite number"),
    "text": (lambda ls: ls[:3] + [ls[3].split(",")[0] + ",abc," + ",".join(ls[3].split(",")[2:])] + ls[4:],
             r"r\.csv, line 4, column gyro_x: 'abc' is not a finite number"),
    "non-increasing time": (lambda ls: ls[:10] + [ls[9]] + ls[11:], r"r\.csv, line 11: time .* does not increase"),
    "non-uniform time": (lambda ls: ls[:1] + [ls[1]] + ls[3:], r"r\.csv, line 3: time step 0\.02 s differs"),
}


@pytest.mark.parametrize("case", CSV_CASES)
def test_bad_csv_is_rejected_naming_file_and_line(written, tmp_path, case):
    mutate, pattern = CSV_CASES[case]
    path = copy_recording(written[1], tmp_path)
    edit_csv(path, mutate)
    with pytest.raises(InputError, match=pattern):
        read_recording(path)


def test_extra_columns_are_ignored(written, tmp_path):
    path = copy_recording(written[1], tmp_path)
    edit_csv(path, lambda ls: [ls[0] + ",temperature"] + [x + ",21.5" for x in ls[1:]])
    np.testing.assert_array_equal(read_recording(path).gyro, written[0].recording.gyro)


TOML_CASES = {
    "unknown letter": ('orientation = "USE"', 'orientation = "USQ"', r"segment 3: orientation 'USQ' has unknown"),
    "left-handed": ('orientation = "USE"', 'orientation = "USW"', r"segment 3: orientation 'USW' is not a right-handed"),
    "chain": ('orientation = "SDE"', 'orientation = "SUW"',
              r"segment 5 \(group 1, static SUW.*does not follow from USE and segment 4.*gives SDE"),
    "angle": ('angle_deg = 90.0', 'angle_deg = 45.0', r"segment 3 .*does not follow from NUE.*gives no orientation"),
    "axis": ('axis = "+Z"', 'axis = "+Q"', r"segment 2: rotation axis '\+Q'"),
    "out of range": ("end_s = 132.0", "end_s = 200.0", r"segment 21 .*lies outside the data"),
    "overlap": ("start_s = 8.0\nend_s = 12.0", "start_s = 7.0\nend_s = 12.0", r"segment 2 .*overlaps"),
    "starts with rotation": ('group = 2\nkind = "static"', 'group = 2\nkind = "rotation"\naxis = "+Y"\nangle_deg = 90.0',
                             r"segment 8 .*starts group 2 with a rotation"),
    "kind": ('kind = "rotation"', 'kind = "spin"', r"segment 2: kind must be 'static' or 'rotation'"),
    "format": ('format = "sins-recording/1"', 'format = "sins-recording/9"', r"format must be 'sins-recording/1'"),
    "latitude": ("latitude_deg = 37.5", "latitude_deg = 137.5", r"latitude_deg 137.5 is outside"),
    "data file": ('data = "r.csv"', 'data = "missing.csv"', r"missing\.csv: no such data file"),
}


@pytest.mark.parametrize("case", TOML_CASES)
def test_bad_description_is_rejected_naming_file_and_segment(written, tmp_path, case):
    old, new, pattern = TOML_CASES[case]
    path = copy_recording(written[1], tmp_path)
    edit_toml(path, old, new)
    with pytest.raises(InputError, match=pattern) as info:
        read_recording(path)
    assert "r.toml" in str(info.value) or "csv" in str(info.value)


def test_alternation_and_group_order_are_checked(written, tmp_path):
    path = copy_recording(written[1], tmp_path)
    # turn the second group's first rotation into a static segment: two statics in a row
    text = path.read_text()
    block = text.split("[[segments]]")
    block[9] = block[9].replace('kind = "rotation"', 'kind = "static"\norientation = "NED"')
    path.write_text("[[segments]]".join(block))
    with pytest.raises(InputError, match=r"segment 9 .*follows a static segment"):
        read_recording(path)


def test_written_recording_follows_the_format_for_an_independent_reader(written):
    """Read our output the way another program that knows only recording-format.md would."""
    import csv
    import tomllib

    sim, path = written
    doc = tomllib.loads(path.read_text())
    assert doc["format"] == "sins-recording/1" and isinstance(doc["name"], str)
    assert set(doc["site"]) >= {"latitude_deg", "height_m"} and doc["imu"]["rate_hz"] == 100.0
    for seg in doc["segments"]:
        assert seg["kind"] in ("static", "rotation") and seg["end_s"] > seg["start_s"]
        assert ("orientation" in seg) if seg["kind"] == "static" else {"axis", "angle_deg"} <= set(seg)
    with open(path.parent / doc["data"], newline="") as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == ["time", "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]
    times = np.array([float(r[0]) for r in rows[1:]])
    dt = 1.0 / doc["imu"]["rate_hz"]
    # the first interval ends at time[0] and is 1/rate long; time is uniform
    assert times[0] == pytest.approx(dt) and np.allclose(np.diff(times), dt)
    assert float(rows[1][5]) == sim.recording.accel[0, 1]


def _retime(path, rate):
    """Rewrite the time column as if the samples came at ``rate`` Hz (full precision)."""
    def mutate(lines):
        out = [lines[0]]
        for k, line in enumerate(lines[1:], start=1):
            out.append(f"{k / rate:.9f}," + line.split(",", 1)[1])
        return out
    edit_csv(path, mutate)


def test_a_time_column_at_another_rate_than_rate_hz_is_rejected_naming_the_file(written, tmp_path):
    """100.05 Hz labelled 100 Hz would put +500 ppm on every scale factor (issue 9)."""
    path = copy_recording(written[1], tmp_path)
    _retime(path, 100.05)
    with pytest.raises(InputError, match=r"r\.csv: the time column runs at 100\.05 Hz, rate_hz says 100 Hz "
                                             r"\(-500 ppm\)"):
        read_recording(path)


def test_a_few_ppm_of_clock_difference_is_a_warning_carried_to_the_report(written, tmp_path):
    path = copy_recording(written[1], tmp_path)
    _retime(path, 100.0005)
    rec = read_recording(path)
    assert len(rec.warnings) == 1 and "-5 ppm" in rec.warnings[0] and "r.csv" in rec.warnings[0]
    assert read_recording(written[1]).warnings == []


def test_a_recording_description_and_a_thermal_model_are_told_from_their_neighbours(tmp_path):
    """What a command is handed is sniffed in data/: a recording description (not a problem file), a thermal
    model (not a parameter table); an unreadable CSV is not a thermal model (its reader names the fault)."""
    from pathlib import Path

    from casadi_sins.data.description import is_recording_description
    from casadi_sins.data.thermal import is_thermal_model

    problems = Path(__file__).resolve().parents[2] / "problems"
    recording = tmp_path / "r.toml"
    recording.write_text('format = "sins-recording/1"\nname = "r"\n')
    assert is_recording_description(recording) and not is_recording_description(problems / "kang2013.toml")
    model, table = tmp_path / "thermal.csv", tmp_path / "t.csv"
    model.write_text("parameter,unit,p_ref,a1,a2\n")
    table.write_text("parameter,unit,value,sigma\n")
    assert is_thermal_model(model) and not is_thermal_model(table) and not is_thermal_model(tmp_path / "none.csv")
