"""Is a Monte Carlo's sigma honest?  What N runs can tell, per parameter and jointly.

An RMS error over ``N`` runs is itself uncertain: with an exact sigma and Gaussian errors,
``N (RMS / sigma)^2`` is chi-square with ``N`` degrees of freedom, so at 20 runs the ratio falls
anywhere in 0.69-1.31 (95 %), and among 21 parameters about one falls outside that band by chance.
A ratio outside the band is evidence against the sigma only when more fall outside than chance
allows; the sharper test is joint: the sum over runs of each run's joint chi-square (the error
against the full covariance, :func:`model.parameters.joint_chi_square`) is chi-square with
``21 N`` degrees of freedom when the covariance is honest, correlations included.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
from scipy import stats

#: Two-sided probability of the bands.
LEVEL = 0.95


def rms_ratio_band(runs: int, level: float = LEVEL) -> tuple[float, float]:
    """The range of RMS error / sigma that ``runs`` runs give with probability ``level`` for an exact sigma."""
    tail = (1.0 - level) / 2.0
    return (float(np.sqrt(stats.chi2.ppf(tail, runs) / runs)), float(np.sqrt(stats.chi2.ppf(1.0 - tail, runs) / runs)))


def chi_square_band(dof: int, level: float = LEVEL) -> tuple[float, float]:
    """The ``level`` two-sided range of a chi-square with ``dof`` degrees of freedom."""
    tail = (1.0 - level) / 2.0
    return float(stats.chi2.ppf(tail, dof)), float(stats.chi2.ppf(1.0 - tail, dof))


@dataclasses.dataclass
class Consistency:
    """One solver's Monte Carlo against its sigma.

    Attributes
    ----------
    solver : str
    runs : int
        Runs that calibrated.
    band : (float, float)
        95 % range of one parameter's RMS/sigma for an exact sigma at ``runs``.
    outside : list of str
        Parameters whose RMS/sigma is outside ``band``.
    expected_outside : float
        How many fall outside by chance (5 % of the parameters).
    outside_p : float
        Probability of at least ``len(outside)`` outside by chance (binomial, parameters taken as independent).
    joint : float
        Sum over runs of the joint chi-square.
    joint_dof : int
    joint_band : (float, float)
    """

    solver: str
    runs: int
    band: tuple[float, float]
    outside: list[str]
    expected_outside: float
    outside_p: float
    joint: float
    joint_dof: int
    joint_band: tuple[float, float]

    @property
    def joint_in_band(self) -> bool:
        """Whether the summed joint chi-square lies in its 95 % band."""
        return self.joint_band[0] <= self.joint <= self.joint_band[1]

    def line(self) -> str:
        """One sentence for a report."""
        lo, hi = self.band
        out = ", ".join(self.outside) if self.outside else "none"
        joint = (f"summed joint chi-square {self.joint:.0f} for {self.joint_dof} degrees of freedom "
                 f"(95 % band {self.joint_band[0]:.0f}-{self.joint_band[1]:.0f}: "
                 f"{'in band' if self.joint_in_band else 'OUT of band'})")
        return (f"{self.solver}: at {self.runs} runs an exact sigma gives RMS/sigma in {lo:.2f}-{hi:.2f} (95 %); "
                f"outside: {out} ({len(self.outside)}, {self.expected_outside:.1f} expected by chance, "
                f"P = {self.outside_p:.2f}); {joint}")


def consistency(rows: pd.DataFrame, summary: pd.DataFrame, level: float = LEVEL) -> list[Consistency]:
    """Per solver: the per-parameter band check and the joint chi-square test of a Monte Carlo
    (``rows`` and ``summary`` of :mod:`studies.montecarlo`)."""
    ok = rows[rows["failed"] == ""] if "failed" in rows else rows
    out = []
    for solver, part in summary.groupby("solver", sort=False):
        runs = int(part["runs"].min())
        if runs < 2:
            continue
        band = rms_ratio_band(runs, level)
        ratio = part["rms_over_sigma"].to_numpy()
        outside = [p for p, r in zip(part["parameter"], ratio) if not band[0] <= r <= band[1]]
        chance = 1.0 - level
        per_run = ok[ok["solver"] == solver].groupby("seed")["chi_square"].first().to_numpy(float)
        dof = len(part) * len(per_run)
        out.append(Consistency(solver, runs, band, outside, chance * len(part),
                               float(stats.binom.sf(len(outside) - 1, len(part), chance)), float(np.sum(per_run)),
                               dof, chi_square_band(dof, level)))
    return out
