"""What a Monte Carlo of N runs can say of a sigma: the per-parameter band and the joint chi-square."""

import numpy as np
import pandas as pd
import pytest

from casadi_sins.model.registry import NAMES
from casadi_sins.studies import montecarlo as MC
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
    honest = [consistency(r, MC.summary(r))[0] for r in (_rows(1.0, seed=s) for s in range(20))]
    assert sum(c.joint_in_band for c in honest) >= 17  # 95 % each
    assert np.mean([len(c.outside) for c in honest]) == pytest.approx(0.05 * len(NAMES), abs=0.8)
    optimistic = consistency(_rows(1.4), MC.summary(_rows(1.4)))[0]
    assert not optimistic.joint_in_band and optimistic.joint > optimistic.joint_band[1]
    assert len(optimistic.outside) > 5 and optimistic.outside_p < 0.01
    assert "OUT of band" in optimistic.line()


def test_failed_runs_are_left_out_of_the_joint_test():
    rows = _rows(1.0)
    rows.loc[rows["seed"] == 10003, "failed"] = "did not converge"
    check = consistency(rows, MC.summary(rows))[0]
    assert check.runs == 19 and check.joint_dof == 19 * len(NAMES)
