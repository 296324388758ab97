"""What a Monte Carlo of N runs can say of a sigma: the per-parameter band and the joint chi-square."""

import numpy as np
import pandas as pd
import pytest

from casadi_sins.model.registry import NAMES
from casadi_sins.studies.consistency import consistency, rms_ratio_band


@pytest.mark.parametrize("runs", [5, 20, 50])
def test_the_band_holds_95_percent_of_rms_ratios_of_an_exact_sigma(runs):
    rng = np.random.default_rng(runs)
    z = rng.standard_normal((20000, runs))
    ratio = np.sqrt(np.mean(z**2, axis=1))
    lo, hi = rms_ratio_band(runs)
    inside = np.mean((ratio >= lo) & (ratio <= hi))
    assert inside == pytest.approx(0.95, abs=0.006)
    assert np.mean(ratio < lo) == pytest.approx(0.025, abs=0.004)


def _rows(scale: float, runs: int = 20, seed: int = 0) -> pd.DataFrame:
    """Monte Carlo rows of one solver: independent errors of ``scale`` x the stated sigma."""
    rng = np.random.default_rng(seed)
    rows = []
    for k in range(runs):
        z = scale * rng.standard_normal(len(NAMES))
        for name, zi in zip(NAMES, z):
            rows.append({"seed": 10000 + k, "solver": "nlp", "parameter": name, "group": "g", "unit": "u",
                         "error": 0.5 * zi, "sigma": 0.5, "first_iteration_error": 0.5 * zi,
                         "chi_square": float(np.sum(z**2)), "failed": ""})
    return pd.DataFrame(rows)


def test_honest_sigma_passes_the_joint_test_and_inflated_errors_fail_it():
    honest = [consistency(r)[0] for r in (_rows(1.0, seed=s) for s in range(20))]
    assert sum(c.joint_in_band for c in honest) >= 17  # 95 % each
    assert np.mean([len(c.outside) for c in honest]) == pytest.approx(0.05 * len(NAMES), abs=0.8)
    optimistic = consistency(_rows(1.4))[0]
    assert not optimistic.joint_in_band and optimistic.joint > optimistic.joint_band[1]
    assert len(optimistic.outside) > 5 and optimistic.outside_p < 0.01
    assert "OUT of band" in optimistic.line()


def test_failed_runs_are_left_out_of_the_joint_test():
    rows = _rows(1.0)
    rows.loc[rows["seed"] == 10003, "failed"] = "did not converge"
    check = consistency(rows)[0]
    assert check.runs == 19 and check.joint_dof == 19 * len(NAMES)


def test_a_run_whose_own_sigma_is_larger_is_judged_by_its_own_sigma():
    """A run that states a sigma 5 x larger, with errors to match, is no evidence against the sigma (its z is
    as any other's); RMS error over the mean sigma would read about 0.6 and fall outside the band."""
    rows = _rows(1.0, seed=3)
    wide = rows["seed"] == 10007
    rows.loc[wide, ["error", "sigma"]] *= 5.0
    check = consistency(rows)[0]
    plain = consistency(_rows(1.0, seed=3))[0]
    assert check.rms_z == pytest.approx(plain.rms_z) and check.outside == plain.outside


def test_runs_without_a_joint_chi_square_are_left_out_of_its_degrees_of_freedom():
    rows = _rows(1.0)
    rows.loc[rows["seed"] == 10004, "chi_square"] = np.nan
    check = consistency(rows)[0]
    assert check.joint_dof == 19 * len(NAMES) and np.isfinite(check.joint)
    rows["chi_square"] = np.nan
    none = consistency(rows)[0]
    assert none.joint_dof == 0 and not none.joint_in_band and "n/a" in none.line()


def test_montecarlo_files_of_a_dotted_name_keep_the_whole_name(kang_problem, tmp_path):
    import dataclasses

    from casadi_sins.studies import montecarlo as MC

    rows = _rows(1.0)
    problem = dataclasses.replace(kang_problem, name="unit.v2")
    summary = MC.with_prediction(MC.summary(rows), np.full(len(NAMES), 0.5))
    files = MC.montecarlo_files(problem, rows, summary, tmp_path, 20, 1.0)
    names = sorted(p.name for p in files)
    assert names == ["unit.v2-montecarlo-runs.csv", "unit.v2-montecarlo-runs.md", "unit.v2-montecarlo.csv",
                     "unit.v2-montecarlo.md", "unit.v2-montecarlo.png"]
    assert b"## Is the sigma honest?" in files[tmp_path / "unit.v2-montecarlo.md"]
