"""The time-domain check: a Monte Carlo of the nonlinear navigation against the covariance.

The full check of the bar (50 runs per source, 6 h, three schemes) is ``benchmarks/bench_modulation.py``
(results/modulation/montecarlo.md); here one period of the 16-position scheme, cheap enough for every run
of the tests."""

import dataclasses
import math

import numpy as np
import pytest

from casadi_sins.studies.modulation.montecarlo import monte_carlo, montecarlo_files, run_schemes
from casadi_sins.studies.modulation.schemes import load_scheme
from casadi_sins.studies.modulation.sources import NOISES

RUNS = 50
#: Relative spread (1 sigma) of the RMS over RUNS runs of a two-component Gaussian error: chi with 2 RUNS
#: degrees of freedom, sqrt(1 / (4 RUNS)).
SPREAD = math.sqrt(1.0 / (4 * RUNS))


@pytest.fixture(scope="module")
def sheet_with_asymmetry(guan_sheet):
    p0 = guan_sheet.p0.copy()
    asym = guan_sheet.groups()["gyro scale-factor asymmetry"]
    p0[asym, asym] = (5e-6) ** 2  # 5 ppm, to exercise the term
    return dataclasses.replace(guan_sheet, p0=p0)


@pytest.mark.slow
def test_monte_carlo_confirms_the_covariance_per_source(sheet_with_asymmetry, guan_site):
    """One period (0.25 h) of the 16-position dual-axis scheme: every turn-rate coupling at work.

    The constants are drawn moment-matched: their MC RMS must equal the covariance's sigma up to the
    model's linearisation (2 %); the noises cannot be matched: within 4 sigma of their sampling spread."""
    res = monte_carlo(load_scheme("dual-axis-16"), sheet_with_asymmetry, guan_site, 0.25, runs=RUNS, seed=0)
    assert len(res["groups"]) == 11
    for group, v in res["groups"].items():
        tol = 4 * SPREAD if group in NOISES else 0.02
        for key in ("ratio_of_max", "ratio_pooled"):
            assert abs(v[key] - 1.0) <= tol, (group, key, v[key])
    assert res["reference_run_max_error_m"] < 1.0


@pytest.mark.slow
def test_plain_draws_differ_from_the_covariance_only_by_their_sampling(sheet_with_asymmetry, guan_site):
    """Plain random draws: the MC against the covariance of the very errors drawn agrees to 1 %."""
    res = monte_carlo(load_scheme("single-axis-4pos"), sheet_with_asymmetry.aligned(guan_site, np.eye(3)),
                      guan_site, 0.5, runs=RUNS, seed=1, matched=False)
    for group, v in res["groups"].items():
        if "ratio_given_draws" in v:
            assert v["ratio_given_draws"] == pytest.approx(1.0, abs=0.01), group


def test_several_schemes_in_order_and_their_files(guan_sheet, guan_site, tmp_path):
    """Fewer runs than a group has numbers (6 misalignments, 3 runs): drawn plainly, not refused."""
    schemes = [load_scheme("single-axis-continuous"), load_scheme("strapdown")]
    results = run_schemes(schemes, guan_sheet, guan_site, 0.05, runs=3, seed=2, turn_step_deg=5.0)
    assert [r["scheme"] for r in results] == ["single-axis-continuous", "strapdown"]
    files = montecarlo_files(results, [], tmp_path)
    assert set(files) == {tmp_path / "montecarlo.json", tmp_path / "montecarlo.md"}
    assert b"| single-axis-continuous |" in files[tmp_path / "montecarlo.md"]
