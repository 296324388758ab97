"""Exports of the parameter table: compensation matrices (JSON, YAML) and the PSINS clbt layout."""

import json

import numpy as np

from casadi_sins.cli import main
from casadi_sins.data.tables import write_table
from casadi_sins.model import registry as R
from casadi_sins.model.output import compensate
from casadi_sins.report.exports import compensation, psins_clbt, to_yaml


def test_compensation_matrices_reproduce_the_compensated_increments(kang_problem):
    params = kang_problem.truth
    pulses = np.random.default_rng(0).normal(size=(5, 6)) * 1e3
    dt = 0.01
    data = compensation(params, {"unit_id": "SN7"})
    dtheta, dv = compensate(pulses[:, :3], pulses[:, 3:], params.values, dt)
    for sensor, expected, raw in (("gyro", dtheta, pulses[:, :3]), ("accel", dv, pulses[:, 3:])):
        m, c = np.array(data[sensor]["M"]), np.array(data[sensor]["c"])
        np.testing.assert_allclose(raw @ m.T + c * dt, expected, rtol=1e-12, atol=1e-18)
        np.testing.assert_allclose(np.array(data[sensor]["K_inverse"]) @ np.diag(data[sensor]["scale"]), m, rtol=1e-12)
    assert data["metadata"]["unit_id"] == "SN7" and len(data["parameters"]) == 21


def test_yaml_and_psins_texts_carry_the_same_numbers(kang_problem):
    params = kang_problem.truth
    data = compensation(params)
    text = to_yaml(data)
    assert "gyro:\n  M: [[" in text and "format: \"casadi-sins-compensation/1\"" in text
    clbt = psins_clbt(params)
    k_g = np.array(data["gyro"]["M"]) / np.mean(params.values[R.GYRO_SCALE])
    first_row = clbt.split("clbt.Kg = [")[1].split(";")[0].split()
    np.testing.assert_allclose([float(x) for x in first_row], k_g[0], rtol=1e-12)


def test_export_command_writes_json(tmp_path, kang_problem):
    table = write_table(tmp_path / "t.csv", kang_problem.truth)
    assert main(["export", str(table), "--format", "json", "--out", str(tmp_path / "c.json"), "--unit-id", "A1"]) == 0
    data = json.loads((tmp_path / "c.json").read_text())
    assert data["metadata"]["unit_id"] == "A1" and np.array(data["accel"]["M"]).shape == (3, 3)
