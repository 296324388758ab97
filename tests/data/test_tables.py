"""The parameter table: round trip, natural units, errors naming file and line."""

import numpy as np
import pytest

from casadi_sins.core.errors import InputError
from casadi_sins.data.tables import read_table, write_table
from casadi_sins.model import registry as R
from casadi_sins.model.parameters import ParameterSet


def random_parameters(rng):
    p = np.zeros(R.N_PARAMS)
    p[R.ACCEL_BIAS] = rng.normal(0, 0.01, 3)
    p[R.ACCEL_SCALE] = 3.5e-4 * (1 + rng.normal(0, 0.01, 3))
    p[R.ACCEL_MISALIGN] = rng.normal(0, 2e-3, 3)
    p[R.GYRO_BIAS] = rng.normal(0, 1e-6, 3)
    p[R.GYRO_SCALE] = 1e-7 * (1 + rng.normal(0, 0.01, 3))
    p[R.GYRO_MISALIGN] = rng.normal(0, 2e-3, 6)
    return p


def test_table_round_trip(tmp_path):
    rng = np.random.default_rng(5)
    params = ParameterSet(random_parameters(rng), sigma=np.abs(random_parameters(rng)) * 1e-3)
    path = write_table(tmp_path / "p.csv", params)
    header = path.read_text().splitlines()[0]
    assert header.startswith("parameter,unit,value,sigma")
    back = read_table(path)
    np.testing.assert_allclose(back.values, params.values, rtol=1e-11)
    np.testing.assert_allclose(back.sigma, params.sigma, rtol=1e-11)
    truth = write_table(tmp_path / "t.csv", params, as_truth=True)
    assert truth.read_text().splitlines()[0] == "parameter,unit,value"
    assert read_table(truth).sigma is None


def test_table_accepts_natural_units(tmp_path):
    path = tmp_path / "t.csv"
    rows = [f"{n},{u},{0.0 if 'scale' not in n else 1e-4}" for n, u in zip(R.NAMES, tuple(R.unit_of(n) for n in R.NAMES))]
    rows[R.NAMES.index("gyro_scale_x")] = "gyro_scale_x,deg/pulse,5.644819e-6"
    path.write_text("parameter,unit,value\n" + "\n".join(rows) + "\n")
    assert read_table(path)["gyro_scale_x"] == pytest.approx(np.radians(5.644819e-6), rel=1e-15)


@pytest.mark.parametrize("mutate,message", [
    (lambda rows: rows[:-1], "missing parameters gyro_misalign_zy"),
    (lambda rows: rows + ["accel_bias_q,m/s^2,0"], "line 23: unknown parameter 'accel_bias_q'"),
    (lambda rows: rows + [rows[0]], "line 23: parameter 'accel_bias_x' given twice"),
    (lambda rows: ["accel_bias_x,m/s^2,nan"] + rows[1:], "line 2: value of accel_bias_x is not finite"),
    (lambda rows: ["accel_bias_x,deg/h,0"] + rows[1:], "line 2: unit 'deg/h' does not fit accel_bias_x"),
    (lambda rows: ["accel_bias_x,furlong,0"] + rows[1:], "line 2: unknown unit 'furlong'"),
])
def test_bad_tables_name_file_and_line(tmp_path, mutate, message):
    rows = [f"{n},{u},1e-4" for n, u in zip(R.NAMES, tuple(R.unit_of(n) for n in R.NAMES))]
    path = tmp_path / "bad.csv"
    path.write_text("parameter,unit,value\n" + "\n".join(mutate(rows)) + "\n")
    with pytest.raises(InputError) as info:
        read_table(path)
    assert str(path) in str(info.value) and message in str(info.value)
