"""A table the calibration's own checks do not trust (issue 38 item 4): the reasons, and what the commands do."""

from __future__ import annotations

import dataclasses
import json

import numpy as np

from casadi_sins.calibrate.trust import MISALIGNMENT_LIMIT, SCALE_CHANGE_LIMIT, implausible
from casadi_sins.cli import commands, main
from casadi_sins.data.description import write_recording
from casadi_sins.data.tables import read_table
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.model.registry import NAMES


def test_values_no_unit_has_are_named(kang_nlp):
    good = kang_nlp.parameters
    assert implausible(good, kang_nlp.initial) == []
    values = good.values.copy()
    values[NAMES.index("accel_scale_x")] *= 1.0 + 2 * SCALE_CHANGE_LIMIT
    values[NAMES.index("gyro_misalign_yx")] = 2 * MISALIGNMENT_LIMIT
    reasons = implausible(ParameterSet(values, covariance=good.covariance), kang_nlp.initial)
    assert len(reasons) == 2 and "accel_scale_x" in reasons[0] and "gyro_misalign_yx" in reasons[1]


def test_calibrate_refuses_a_distrusted_table_and_writes_it_marked_only_when_told(tmp_path, kang_sim, kang_nlp,
                                                                                   monkeypatch, capsys):
    distrusted = dataclasses.replace(kang_nlp, distrust=["the unmodelled rate reached its bound: not to be trusted"])
    monkeypatch.setattr(commands, "calibrate", lambda *args, **kwargs: distrusted)
    path = write_recording(kang_sim.recording, tmp_path / "r.toml")
    out = tmp_path / "out" / "params.csv"
    assert main(["calibrate", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "do not trust" in err and "reached its bound" in err and "--accept-distrusted" in err
    assert not (tmp_path / "out").exists()
    assert main(["calibrate", str(path), "--out", str(out), "--accept-distrusted"]) == 4
    assert "DISTRUSTED" in capsys.readouterr().err
    assert set(np.loadtxt(out, delimiter=",", skiprows=1, usecols=-1, dtype=str)) == {"distrusted"}
    assert np.array_equal(read_table(out).values, kang_nlp.parameters.values)  # still a table to read
    report = json.loads((tmp_path / "out" / "params.report.json").read_text())
    assert report["distrusted"] == distrusted.distrust
    assert "NOT TO BE TRUSTED" in (tmp_path / "out" / "params.report.md").read_text()


def test_an_unmodelled_term_at_a_top_raised_by_its_own_residuals_is_no_distrust():
    """A MEMS unit whose gyro means the data cannot bound (imucal's session segmented from its raw CSV) reaches
    the top its residuals set: a warning that they weigh nothing, not distrust; the fixed navigation-grade top
    reached is distrust."""
    from casadi_sins.calibrate.nlp.likelihood import UNMODELLED_RATE_RANGE, unmodelled_at_bounds
    from casadi_sins.model.noise import SensorNoise

    fixed = UNMODELLED_RATE_RANGE[1]
    raised = SensorNoise(unmodelled_rate=100 * fixed)
    tops = {"unmodelled_rate": 100 * fixed}
    (warning,) = unmodelled_at_bounds(raised, tops)
    assert "do not bound it" in warning and "not to be trusted" not in warning
    assert unmodelled_at_bounds(raised, tops, binding_only=True) == []
    at_fixed = SensorNoise(unmodelled_rate=fixed)
    (distrust,) = unmodelled_at_bounds(at_fixed, {"unmodelled_rate": fixed}, binding_only=True)
    assert "not to be trusted" in distrust
