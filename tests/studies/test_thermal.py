"""The thermal fit: honest sigma at a left-out temperature, recovered coefficients, file round trips, the command."""

from __future__ import annotations

import json

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.data.tables import read_table, write_table
from casadi_sins.data.thermal import read_thermal, write_thermal
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.model.registry import NAMES, natural_scale_of, relative_mask
from casadi_sins.studies.thermal.fit import Point, fit_thermal

TEMPS = (-30.0, -10.0, 25.0, 40.0, 60.0)


def _unit(rng):
    """A unit: nominal values, a correlated covariance (natural sigma ~0.2), its temperature coefficients."""
    nominal = np.zeros(len(NAMES))
    nominal[relative_mask(NAMES)] = 1e-5
    size = natural_scale_of(NAMES) * np.where(relative_mask(NAMES), 1e-5, 1.0)
    a = rng.normal(size=(len(NAMES), len(NAMES)))
    corr = a @ a.T + 5 * np.eye(len(NAMES))
    d = np.sqrt(np.diag(corr))
    cov = corr / np.outer(d, d) * np.outer(0.2 * size, 0.2 * size)
    return nominal, size, cov


def _points(rng, nominal, size, cov, a1, a2, temps=TEMPS):
    chol = np.linalg.cholesky(cov)
    truth = lambda t: nominal + a1 * (t - 25.0) + a2 * (t - 25.0) ** 2  # noqa: E731
    pts = [Point(t, ParameterSet(truth(t) + chol @ rng.normal(size=len(nominal)), covariance=cov), f"t{t:g}")
           for t in temps]
    return pts, truth


@pytest.mark.parametrize("curvature", [0.0, 0.0005, 0.005])
def test_left_out_temperature_within_sigma(curvature):
    """At 10 degC (not calibrated) the tables' errors follow their sigma: mean z^2 per parameter near 1 or below
    (auto order; weak curvatures included), the linear coefficients within their sigma likewise."""
    rng = np.random.default_rng(1)
    nominal, size, cov = _unit(rng)
    z2, za = [], []
    for _ in range(60):
        a1 = rng.normal(size=len(NAMES)) * size * 0.3
        a2 = rng.normal(size=len(NAMES)) * size * curvature
        pts, truth = _points(rng, nominal, size, cov, a1, a2)
        fit = fit_thermal(pts)
        at = fit.model.at(10.0)
        z2.append(((at.values - truth(10.0)) / at.sigma) ** 2)
        za.append(((fit.model.coefficients[:, 1] - a1) / fit.model.sigma[:, 1]) ** 2)
    assert 0.3 < np.mean(z2) < 1.25
    assert np.mean(za) < 1.25
    assert np.max(z2) < 4.5 ** 2


def test_order_by_evidence():
    """A strong curvature is kept, a straight line drops its a2 (values), yet the a2 sigma stays in the model."""
    rng = np.random.default_rng(2)
    nominal, size, cov = _unit(rng)
    a2 = np.zeros(len(NAMES))
    a2[0] = size[0] * 0.05
    pts, _ = _points(rng, nominal, size, cov, size * 0.3, a2)
    fit = fit_thermal(pts)
    assert fit.model.orders[0] == 2
    assert np.sum(fit.model.orders == 1) >= 12
    ones = fit.model.orders == 1
    assert np.all(fit.model.coefficients[ones, 2] == 0.0) and np.all(fit.model.sigma[ones, 2] > 0)
    forced = fit_thermal(pts, order="1")
    assert np.all(forced.model.orders == 1) and np.all(forced.model.sigma[:, 2] == 0.0)


def test_exact_data_recovered_and_residual_warning():
    """Noise-free tables give the coefficients back; one table moved far off is named in a warning."""
    rng = np.random.default_rng(3)
    nominal, size, cov = _unit(rng)
    a1, a2 = size * 0.3, size * 0.01
    pts, truth = _points(rng, nominal, size, cov * 1e-12, a1, a2)
    fit = fit_thermal(pts, order="2")
    np.testing.assert_allclose(fit.model.coefficients[:, 1] / size, a1 / size, atol=1e-4)
    np.testing.assert_allclose(fit.model.values_at(10.0) / size, truth(10.0) / size, atol=1e-4)
    pts[2].params.values[3] += 1e3 * size[3] * 1e-6
    assert any("t25" in w and NAMES[3] in w for w in fit_thermal(pts, order="2").warnings)


def test_file_round_trip(tmp_path):
    """thermal.csv + thermal.json read back to the same model: every table at any temperature is identical."""
    rng = np.random.default_rng(4)
    nominal, size, cov = _unit(rng)
    pts, _ = _points(rng, nominal, size, cov, size * 0.3, size * 0.002)
    model = fit_thermal(pts).model
    for path, data in write_thermal(tmp_path / "thermal.csv", model).items():
        path.write_bytes(data)
    back = read_thermal(tmp_path / "thermal.csv")
    for t in (-40.0, 10.0, 33.3):
        np.testing.assert_array_equal(back.at(t).values, model.at(t).values)
        np.testing.assert_allclose(back.at(t).covariance, model.at(t).covariance, rtol=1e-12, atol=0)
    assert back.orders.tolist() == model.orders.tolist() and back.range_c == model.range_c


def _tables(tmp_path, rng, with_conditions=True):
    nominal, size, cov = _unit(rng)
    pts, truth = _points(rng, nominal, size, cov, size * 0.3, size * 0.002)
    paths = []
    for p in pts:
        path = tmp_path / f"{p.label}.csv"
        write_table(path, p.params)
        report = {"format": "casadi-sins-report/1", "created": "2026-01-01T00:00:00+00:00",
                  "covariance": p.params.covariance.tolist()}
        if with_conditions:
            report["conditions"] = {"temperature_c": p.temperature_c}
        (tmp_path / f"{p.label}.report.json").write_text(json.dumps(report))
        paths.append(str(path))
    return paths, truth


def test_command_writes_tables_every_command_reads(tmp_path, capsys):
    """thermal with --at writes at-<T>C.csv (read_table) with its covariance report; extrapolation is warned."""
    paths, truth = _tables(tmp_path, np.random.default_rng(5))
    out = tmp_path / "out"
    assert main(["thermal", *paths, "--at", "10", "-45", "--out", str(out), "--no-plots"]) == 0
    assert "extrapolated" in capsys.readouterr().err  # a warning: on standard error
    at = read_table(out / "at-10C.csv")
    report = json.loads((out / "at-10C.report.json").read_text())
    np.testing.assert_allclose(np.sqrt(np.diag(report["covariance"])), at.sigma, rtol=1e-12)
    assert report["conditions"]["temperature_c"] == 10.0
    assert np.all(np.abs((at.values - truth(10.0)) / at.sigma) < 4.5)
    assert (out / "at--45C.csv").exists() and (out / "thermal.md").exists()


def test_command_temperatures_given_or_refused(tmp_path, capsys):
    """Without conditions a table needs NAME.csv@T; without either the command fails in one line, writing nothing."""
    paths, _ = _tables(tmp_path, np.random.default_rng(6), with_conditions=False)
    out = tmp_path / "out"
    assert main(["thermal", *paths, "--out", str(out)]) == 2
    assert "no temperature" in capsys.readouterr().err and not out.exists()
    given = [f"{p}@{t:g}" for p, t in zip(paths, TEMPS)]
    assert main(["thermal", *given, "--out", str(out), "--no-plots"]) == 0
    assert read_thermal(out / "thermal.csv").range_c == (-30.0, 60.0)


def test_two_setpoints_no_residual_warning(tmp_path, capsys):
    """Two temperatures: lines through both points leave no residual to check. No parameter is said to be any
    number of sigma off the curve (a zero residual variance was divided by: 1e300-sigma warnings), on standard
    output, standard error or in thermal.md; the one warning says nothing checks the lines."""
    paths, _ = _tables(tmp_path, np.random.default_rng(8))
    out = tmp_path / "out"
    assert main(["thermal", paths[1], paths[3], "--out", str(out), "--no-plots"]) == 0
    printed = capsys.readouterr()
    written = (out / "thermal.md").read_text()
    for text in (printed.out, printed.err, written):
        assert "sigma off the fitted curve" not in text
        assert "no residual checks them" in printed.err + written
    fit = fit_thermal([Point(-10.0, ParameterSet(np.zeros(3), sigma=np.ones(3), names=NAMES[:3]), "a"),
                       Point(40.0, ParameterSet(np.ones(3), sigma=np.ones(3), names=NAMES[:3]), "b")])
    assert np.all(np.isnan(fit.standardized)) and not any("sigma off" in w for w in fit.warnings)


def test_three_setpoints_order_one_still_checked():
    """With three temperatures a straight line keeps one residual degree of freedom: a point far off is still
    named, with a finite sigma count."""
    rng = np.random.default_rng(9)
    nominal, size, cov = _unit(rng)
    pts, _ = _points(rng, nominal, size, cov, size * 0.3, 0.0 * size, temps=(-10.0, 25.0, 60.0))
    pts[1].params.values[0] += 20 * np.sqrt(cov[0, 0])
    fit = fit_thermal(pts, order="1")
    off = [w for w in fit.warnings if NAMES[0] in w and "sigma off" in w]
    assert off and all(abs(float(w.split(" is ")[1].split()[0])) < 1e6 for w in off)
