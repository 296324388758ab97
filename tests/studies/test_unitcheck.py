"""navcheck and budget on a unit's own static recording with its table; batch on a local Dask cluster."""

import importlib.util

import numpy as np
import pandas as pd
import pytest

from casadi_sins.cli import main
from casadi_sins.core.units import DEG_PER_H
from casadi_sins.data.tables import write_table
from casadi_sins.model import registry as R
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.sim import simulate, write_simulation
from casadi_sins.studies.navcheck import navigation_problem


@pytest.fixture(scope="module")
def static_unit(tmp_path_factory, kang_problem):
    """A 15 min static recording of the paper's unit, its true table (with sigma) and a wrong one."""
    root = tmp_path_factory.mktemp("static")
    sim = simulate(navigation_problem(kang_problem, 600.0, 300.0), seed=2, name="SN42-static")
    rec = write_simulation(sim, root)
    sigma = np.abs(sim.truth.values) * 1e-6 + np.where(R.SCALE_MASK, 0.0, 1e-7)
    good = write_table(root / "good.csv", ParameterSet(sim.truth.values, sigma=sigma))
    wrong = sim.truth.values.copy()
    wrong[R.GYRO_BIAS] += 0.05 * DEG_PER_H
    bad = write_table(root / "bad.csv", ParameterSet(wrong, sigma=sigma))
    return root, rec, good, bad


def test_navcheck_on_the_units_recording_tells_a_good_table_from_a_wrong_one(static_unit, capsys):
    root, rec, good, bad = static_unit
    assert main(["navcheck", str(rec), "--params", str(good), str(bad), "--out", str(root / "nav")]) == 0
    table = pd.read_csv(root / "nav" / "SN42-static-navcheck.csv").set_index("parameters")
    assert table.loc["good", "navigation time (s)"] == pytest.approx(600.0, abs=1.0)
    assert table.loc["bad", "max horizontal error (nmi)"] > 3 * table.loc["good", "max horizontal error (nmi)"]
    assert (root / "nav" / "SN42-static-navcheck.png").exists()


def test_navcheck_on_a_too_short_recording_says_so(static_unit, capsys):
    root, rec, good, _ = static_unit
    assert main(["navcheck", str(rec), "--params", str(good), "--align-s", "900", "--out", str(root / "n2")]) == 2
    assert "too short" in capsys.readouterr().err


def test_budget_on_the_units_recording_measures_its_noise(static_unit, capsys):
    root, rec, good, _ = static_unit
    assert main(["budget", str(rec), "--params", str(good), "--hours", "2", "--out", str(root / "budget")]) == 0
    out = capsys.readouterr().out
    assert "VRW 5 " in out or "VRW 4.9" in out or "VRW 5.0" in out  # 50 ug per sample at 100 Hz: 5 ug/sqrt(Hz)
    assert "orientation ENU" in out
    table = pd.read_csv(root / "budget" / "SN42-static-budget.csv").set_index("source")
    assert table.loc["total", "north 1 h (m)"] > 0 and "east 2 h (m)" in table.columns
    assert main(["budget", str(rec), "--out", str(root / "b2")]) == 2  # a recording's budget needs --params


@pytest.mark.skipif(importlib.util.find_spec("distributed") is None, reason="dask.distributed not installed")
def test_the_units_budget_and_navcheck_are_assembled_as_files_nothing_written(static_unit, tmp_path):
    """The studies return every file of ``budget`` and ``navcheck`` on a recording as bytes (the command only
    writes them): the CSV reads back as the table in full precision, the plot is a PNG, nothing is on disk."""
    import io

    from casadi_sins.data.description import read_recording
    from casadi_sins.data.tables import read_table
    from casadi_sins.studies.unitcheck import recording_budget_files, recording_navigation_files

    root, rec_path, good, _ = static_unit
    rec, params = read_recording(rec_path), read_table(good)
    budget = recording_budget_files(rec, params, "good.csv", tmp_path, hours=2.0)
    stem = tmp_path / "SN42-static-budget"
    assert set(budget.files) == {stem.with_suffix(s) for s in (".csv", ".md", ".png")}
    back = pd.read_csv(io.BytesIO(budget.files[stem.with_suffix(".csv")]))
    assert list(back.columns) == list(budget.shown.columns) and len(back) == len(budget.shown)
    assert budget.files[stem.with_suffix(".png")].startswith(b"\x89PNG")
    assert "good.csv" in budget.files[stem.with_suffix(".md")].decode() and "ARW" in budget.noise
    files, shown = recording_navigation_files(rec, {"good": params.values}, tmp_path, align_s=300.0)
    table = pd.read_csv(io.BytesIO(files[tmp_path / "SN42-static-navcheck.csv"]))
    assert table["navigation time (s)"].iloc[0] == pytest.approx(600.0, abs=1.0) and len(shown) == 1
    assert not any(tmp_path.iterdir())


def test_batch_on_a_local_dask_cluster(tmp_path, short_problem):
    paths = [write_simulation(simulate(short_problem, seed=k, name=f"D{k}"), tmp_path / "rec") for k in range(3)]
    assert main(["batch", *map(str, paths), "--out", str(tmp_path / "out"), "--dask", "local", "--workers", "2"]) == 0
    table = pd.read_csv(tmp_path / "out" / "fleet.csv")
    assert list(table["unit_id"]) == ["D0", "D1", "D2"] and (table["status"] == "ok").all()


def test_batch_reports_a_missing_recording_as_a_failed_unit_and_refuses_two_of_one_name(tmp_path, short_problem,
                                                                                        capsys):
    good = write_simulation(simulate(short_problem, seed=1, name="E1"), tmp_path / "a")
    assert main(["batch", str(good), str(tmp_path / "missing.toml"), "--out", str(tmp_path / "out"),
                 "--workers", "1"]) == 2  # a unit failed: non-zero, the other still done
    table = pd.read_csv(tmp_path / "out" / "fleet.csv", keep_default_na=False).set_index("unit_id")
    assert table.loc["E1", "status"] == "ok" and table.loc["missing", "status"] == "failed"
    assert "missing.toml" in table.loc["missing", "message"]
    twin = write_simulation(simulate(short_problem, seed=2, name="E1"), tmp_path / "b")
    assert main(["batch", str(good), str(twin), "--out", str(tmp_path / "out2")]) == 2
    assert "different file names" in capsys.readouterr().err
