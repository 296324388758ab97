"""The Python API of a table: read_table(path).compensate(raw DataFrame) is what `apply` writes."""

import numpy as np
import pandas as pd
import pytest

import casadi_sins
from casadi_sins.cli import main
from casadi_sins.data.tables import write_table
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.sim import simulate, write_simulation


@pytest.fixture(scope="module")
def applied(tmp_path_factory, short_problem):
    tmp = tmp_path_factory.mktemp("api")
    sim = simulate(short_problem, seed=8)
    rec = write_simulation(sim, tmp / "rec")
    sigma = np.abs(sim.truth.values) * 1e-6 + 1e-9
    table = write_table(tmp / "P.csv", ParameterSet(sim.truth.values, sigma=sigma))
    assert main(["apply", str(table), str(rec), "--out", str(tmp / "out")]) == 0
    out = pd.read_csv(tmp / "out" / f"{sim.recording.file_stem}-compensated.csv")
    return table, pd.read_csv(rec.with_suffix(".csv")), out, sim


def test_compensate_equals_applys_output(applied):
    table, raw, out, _ = applied
    mine = casadi_sins.read_table(table).compensate(raw)
    assert list(mine.columns) == list(out.columns) and len(mine) == len(out)
    np.testing.assert_allclose(mine["time"], out["time"], rtol=0, atol=1e-9)
    cols = [c for c in out.columns if c != "time"]
    np.testing.assert_array_equal(mine[cols].to_numpy(), out[cols].to_numpy())  # digit for digit


def test_compensate_with_a_given_rate_and_without_time(applied):
    table, raw, out, sim = applied
    mine = casadi_sins.read_table(table).compensate(raw.drop(columns="time"), rate_hz=sim.recording.rate_hz)
    np.testing.assert_array_equal(mine.to_numpy(), out.drop(columns="time").to_numpy())
    with pytest.raises(ValueError, match="accel_z"):
        casadi_sins.read_table(table).compensate(raw.drop(columns="accel_z"))


def test_matrices_reproduce_compensate(applied):
    table, raw, out, sim = applied
    t = casadi_sins.read_table(table)
    m_g, c_g = t.matrices()["gyro"]
    dn = raw[["gyro_x", "gyro_y", "gyro_z"]].to_numpy(float)[:50]
    np.testing.assert_allclose(dn @ m_g.T + c_g * sim.recording.dt, out[["gyro_x", "gyro_y", "gyro_z"]][:50],
                               rtol=1e-12, atol=1e-18)


def test_write_read_round_trip_is_exact(applied, tmp_path):
    t = casadi_sins.read_table(applied[0])
    again = casadi_sins.read_table(t.write(tmp_path / "copy.csv"))
    assert isinstance(again, casadi_sins.Table)
    np.testing.assert_array_equal(again.values, t.values)
    np.testing.assert_array_equal(again.sigma, t.sigma)
    assert again.names == t.names
