"""Error sheets and calibrated tables (sigma, covariance CSV, covariance of the companion report) -> the
initial covariance of the error state."""

import json

import numpy as np
import pytest

from casadi_sins.core import units
from casadi_sins.core.errors import InputError
from casadi_sins.core.units import TO_SI
from casadi_sins.model.registry import NAMES
from casadi_sins.studies.modulation import model as M
from casadi_sins.data.record import read_record
from casadi_sins.studies.modulation.calibrated import table_sources
from casadi_sins.studies.modulation.covariance import propagate
from casadi_sins.studies.modulation.schemes import load_scheme
from casadi_sins.studies.modulation.sources import load_sheet, parse_sheet

HEADER = "parameter,unit,value,sigma"


def test_the_table1_sheet_in_si(guan_sheet):
    sig = np.sqrt(np.diag(guan_sheet.p0))
    assert sig[0] == pytest.approx(10 * units.ARCSEC) and sig[2] == pytest.approx(90 * units.ARCSEC)
    np.testing.assert_allclose(sig[M.GYRO_BIAS], 0.01 * units.DEG_PER_H)
    np.testing.assert_allclose(sig[M.GYRO_MISALIGN], 3 * units.ARCSEC)
    np.testing.assert_allclose(sig[M.ACCEL_BIAS], 30 * units.UG)
    np.testing.assert_allclose(guan_sheet.gyro_arw, 0.002 * units.DEG / 60)  # deg/sqrt(h) -> rad/sqrt(s)
    np.testing.assert_allclose(guan_sheet.accel_vrw, 5 * units.UG)
    assert not np.any(sig[guan_sheet.groups()["gyro scale-factor asymmetry"]])


def test_shipped_sheets_by_name(guan_sheet):
    sheet = load_sheet("guan2023-table1")
    np.testing.assert_array_equal(sheet.p0, guan_sheet.p0)
    assert sheet.origin == "guan2023-table1 (shipped)"
    with pytest.raises(InputError, match="no such error sheet .*yu-ruan2014-sim"):
        load_sheet("no-such-sheet")


def test_per_axis_values_and_3_sigma_bounds():
    sheet = parse_sheet({"sigma_level": 3, "gyro": {"bias_deg_h": [0.03, 0.06, 0.09]}}, "s.toml")
    np.testing.assert_allclose(np.sqrt(np.diag(sheet.p0))[M.GYRO_BIAS], [0.01, 0.02, 0.03] * np.array(units.DEG_PER_H))


@pytest.mark.parametrize("data,message", [
    ({"gyro": {"bias_deg_h": 0.01}}, "sigma_level"),
    ({"sigma_level": 1, "gyro": {"bias": 0.01}}, "unknown key"),
    ({"sigma_level": 1, "gyro": {"bias_deg_h": [0.1, 0.2]}}, "one number or 3"),
    ({"sigma_level": 1, "gyro": {"bias_deg_h": -0.1}}, "negative"),
    ({"sigma_level": 1, "gyro": {"bias_deg_h": "0.1"}}, "not a number"),
    ({"sigma_level": 0, "gyro": {"bias_deg_h": 0.1}}, "sigma_level must be a positive"),
    ({"sigma_level": 1, "magnetometer": {}}, "unknown key"),
    ({"sigma_level": 1, "gyro": 3}, "must be a table"),
])
def test_bad_sheets(data, message):
    with pytest.raises(InputError, match=message) as exc:
        parse_sheet(data, "s.toml")
    assert str(exc.value).startswith("s.toml: ")


@pytest.mark.parametrize("first_line", ["", 'format = "casadi-sins-problem/1"\n'])
def test_a_sheet_file_must_say_its_format(tmp_path, first_line):
    path = tmp_path / "s.toml"
    path.write_text(first_line + "sigma_level = 1\n[gyro]\nbias_deg_h = 0.01\n")
    with pytest.raises(InputError, match="format must be 'casadi-sins-errors/1'"):
        load_sheet(path)


def write_table(tmp_path, extra_rows=(), name="t"):
    """A calibrated table: 2 ppm relative scale sigma, biases 7 ug / 0.002 deg/h, misalignments 1.5"."""
    rows = [HEADER]
    for n in NAMES:
        if n.startswith("gyro_scale"):
            rows.append(f"{n},rad/pulse,2e-6,4e-12")  # 2 ppm relative
        elif n.startswith("accel_scale"):
            rows.append(f"{n},m/s/pulse,1e-4,2e-10")
        elif "_bias_" in n:
            accel = n.startswith("accel")
            rows.append(f"{n},{'ug' if accel else 'deg/h'},0,{7 if accel else 0.002}")
        else:
            rows.append(f"{n},arcsec,0,1.5")
    path = tmp_path / f"{name}.csv"
    path.write_text("\n".join(rows + list(extra_rows)) + "\n")
    return path


def table_sigma():
    """The SI sigma of :func:`write_table`'s 21 rows (values, not relative)."""
    out = []
    for n in NAMES:
        if n.startswith("gyro_scale"):
            out.append(4e-12)
        elif n.startswith("accel_scale"):
            out.append(2e-10)
        elif "_bias_" in n:
            out.append(7 * TO_SI["ug"] if n.startswith("accel") else 0.002 * TO_SI["deg/h"])
        else:
            out.append(1.5 * TO_SI["arcsec"])
    return np.array(out)


def test_a_table_replaces_the_sensor_part_of_a_sheet(tmp_path, guan_sheet):
    src = table_sources(write_table(tmp_path), sheet=guan_sheet)
    sig = np.sqrt(np.diag(src.p0))
    np.testing.assert_allclose(sig[M.GYRO_SCALE], 2e-6)
    np.testing.assert_allclose(sig[M.ACCEL_SCALE], 2e-6)
    np.testing.assert_allclose(sig[M.GYRO_BIAS], 0.002 * units.DEG_PER_H)
    np.testing.assert_allclose(sig[M.ACCEL_BIAS], 7 * units.UG)
    np.testing.assert_allclose(sig[:3], np.sqrt(np.diag(guan_sheet.p0))[:3])  # initial errors from the sheet
    np.testing.assert_allclose(src.gyro_arw, guan_sheet.gyro_arw)
    assert not src.correlated


def correlated(sigma, rho=0.5):
    cov = np.diag(sigma**2)
    i, j = NAMES.index("gyro_bias_x"), NAMES.index("gyro_bias_y")
    cov[i, j] = cov[j, i] = rho * sigma[i] * sigma[j]
    return cov, i, j


def test_the_covariance_of_the_companion_report_is_read(tmp_path):
    table = write_table(tmp_path)
    assert read_record(table).covariance is None  # no report
    (tmp_path / "t.report.json").write_text(json.dumps({"solver": "nlp"}))
    assert read_record(table).covariance is None  # a report without a covariance
    cov, i, j = correlated(table_sigma())
    (tmp_path / "t.report.json").write_text(json.dumps({"solver": "nlp", "covariance": cov.tolist()}))
    src = table_sources(table)
    assert src.correlated and "t.report.json" in src.origin
    k, m = M.N_NAV + i, M.N_NAV + j
    assert src.p0[k, m] == pytest.approx(0.5 * np.sqrt(src.p0[k, k] * src.p0[m, m]))


def test_a_covariance_csv_comes_before_the_report(tmp_path):
    table = write_table(tmp_path)
    (tmp_path / "t.report.json").write_text(json.dumps({"covariance": "not read"}))
    cov, i, j = correlated(table_sigma(), -0.3)
    lines = ["parameter," + ",".join(NAMES)] + [f"{n}," + ",".join(f"{x:.17g}" for x in row)
                                                for n, row in zip(NAMES, cov)]
    path = tmp_path / "c.csv"
    path.write_text("\n".join(lines) + "\n")
    src = table_sources(table, covariance=path)
    assert src.correlated and src.p0[M.N_NAV + i, M.N_NAV + j] < 0


@pytest.mark.parametrize("content,message", [
    ("{", "not a JSON calibration report"),
    (json.dumps({"covariance": [[1.0]]}), "must be a list of 21 lists of 21 numbers"),
    (json.dumps({"covariance": [["a"] * 21] * 21}), "not a number"),
])
def test_a_broken_report_is_named(tmp_path, content, message):
    table = write_table(tmp_path)
    (tmp_path / "t.report.json").write_text(content)
    with pytest.raises(InputError, match=message) as exc:
        table_sources(table)
    assert exc.value.path == tmp_path / "t.report.json"


@pytest.mark.parametrize("change,message", [
    (lambda c: c * 2.0, "diagonal does not match"),
    (lambda c: c + np.triu(np.full_like(c, 1e-20), 1), "not symmetric"),
])
def test_a_report_covariance_that_does_not_fit_the_table(tmp_path, change, message):
    table = write_table(tmp_path)
    cov, _, _ = correlated(table_sigma())
    (tmp_path / "t.report.json").write_text(json.dumps({"covariance": change(cov).tolist()}))
    with pytest.raises(InputError, match=message):
        table_sources(table)


def test_every_group_of_an_extended_table_is_a_source(tmp_path):
    """Issue 39: the modulation state is the navigation errors followed by the registry's names of the table."""
    table = write_table(tmp_path, ["accel_time_offset,ms,0.1,0.01"])
    src = table_sources(table)
    assert src.names == NAMES + ("accel_time_offset",) and "left out" not in src.origin
    assert np.sqrt(src.p0[-1, -1]) == pytest.approx(0.01e-3)
    assert "gyro/accel time offset" in src.groups()
    np.testing.assert_allclose(np.sqrt(np.diag(src.p0))[M.GYRO_SCALE], 2e-6)


def test_a_table_without_sigma(tmp_path):
    rows = write_table(tmp_path).read_text().splitlines()
    path = tmp_path / "values.csv"
    path.write_text("\n".join(row.rsplit(",", 1)[0] for row in rows) + "\n")  # parameter,unit,value
    with pytest.raises(InputError, match="no sigma"):
        table_sources(path)


def test_alignment_makes_the_initial_tilt_cancel_the_accelerometer_bias(guan_sheet, guan_site):
    """Aligned on a level ENU IMU, an east accelerometer bias is exactly cancelled by the tilt it causes."""
    aligned = guan_sheet.aligned(guan_site, np.eye(3))
    x = np.zeros(len(guan_sheet.p0))
    x[M.INDEX["accel_bias_x"]] = 30 * units.UG
    prop = propagate(load_scheme("strapdown"), guan_site, 2.0, np.zeros(3), np.zeros(3))
    assert np.abs(prop.mean(aligned.initial_map() @ x)).max() < 1e-6  # m, round-off
    assert np.abs(prop.mean(x)[:, 2:]).max() > 100.0  # not aligned: ~ R * 3e-5 rad of Schuler swing
    assert set(guan_sheet.groups()) >= {"gyro scale-factor asymmetry", "initial heading"}


def test_a_tables_gyro_scale_asymmetry_and_g_sensitivity_are_sources(tmp_path):
    """The registry's names (``gyro_scale_asym_*``, the term ``A_i |w_i|``) and the g-sensitivity: the table's
    sigma lands on their states, in the registry's order, in natural units converted by the registry."""
    rows = [f"gyro_scale_asym_{a},ppm,3,{s}" for a, s in zip("xyz", (0.05, 0.06, 0.07))]
    rows += [f"gyro_gsens_{i}{j},deg/h/g,0.001,0.0001" for i in "xyz" for j in "xyz"]
    src = table_sources(write_table(tmp_path, rows))
    groups = src.groups()
    sig = np.sqrt(np.diag(src.p0))
    np.testing.assert_allclose(sig[groups["gyro scale-factor asymmetry"]], np.array([0.05, 0.06, 0.07]) * 1e-6)
    np.testing.assert_allclose(sig[groups["gyro g-sensitivity"]], 0.0001 * units.DEG_PER_H / 9.80665)
    assert src.state_names[-3:] == ("gyro_scale_asym_x", "gyro_scale_asym_y", "gyro_scale_asym_z")
