"""Is a Monte Carlo's sigma honest?  What N runs can tell, per parameter and jointly.

Each run states its own sigma, so the statistic is per run: ``z = error / sigma``.  An RMS of ``z``
over ``N`` runs is itself uncertain: with an exact sigma and Gaussian errors ``N rms(z)^2`` is
chi-square with ``N`` degrees of freedom, so at 20 runs it falls anywhere in 0.69-1.31 (95 %), and
among 21 parameters about one falls outside that band by chance.  (RMS error over the *mean* sigma,
the Monte Carlo table's column, is not chi-square when the sigma changes from run to run.)  A value
outside the band is evidence against the sigma only when more fall outside than chance allows; the
sharper test is joint: the sum over runs of each run's joint chi-square (the error against the full
covariance, :func:`model.parameters.joint_chi_square`) is chi-square with ``21 N`` degrees of freedom
when the covariance is honest, correlations included.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

#: Two-sided probability of the bands.
LEVEL = 0.95


def rms_ratio_band(runs: int, level: float = LEVEL) -> tuple[float, float]:
    """The range of RMS error / sigma that ``runs`` runs give with probability ``level`` for an exact sigma."""
    from scipy import stats  # loaded when a Monte Carlo is judged, not at every command's start

    tail = (1.0 - level) / 2.0
    return (float(np.sqrt(stats.chi2.ppf(tail, runs) / runs)), float(np.sqrt(stats.chi2.ppf(1.0 - tail, runs) / runs)))


def chi_square_band(dof: int, level: float = LEVEL) -> tuple[float, float]:
    """The ``level`` two-sided range of a chi-square with ``dof`` degrees of freedom."""
    from scipy import stats

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
    rms_z : dict of str -> float
        Per parameter, the RMS over runs of error / sigma (each run's own sigma).
    band : (float, float)
        95 % range of one parameter's ``rms_z`` for an exact sigma at ``runs``.
    outside : list of str
        Parameters whose ``rms_z`` is outside ``band``.
    expected_outside : float
        How many fall outside by chance (5 % of the parameters).
    outside_p : float
        Probability of at least ``len(outside)`` outside by chance (binomial, parameters taken as independent).
    joint : float
        Sum over runs of the joint chi-square (NaN when no run has one: no or a singular covariance).
    joint_dof : int
        Degrees of freedom of ``joint``: parameters times the runs that have a joint chi-square.
    joint_band : (float, float)
    """

    solver: str
    runs: int
    rms_z: dict
    band: tuple[float, float]
    outside: list[str]
    expected_outside: float
    outside_p: float
    joint: float
    joint_dof: int
    joint_band: tuple[float, float]

    @property
    def joint_in_band(self) -> bool:
        """Whether the summed joint chi-square lies in its 95 % band (False when it is not known)."""
        return bool(self.joint_band[0] <= self.joint <= self.joint_band[1])

    def line(self) -> str:
        """One sentence for a report."""
        lo, hi = self.band
        out = ", ".join(self.outside) if self.outside else "none"
        values = list(self.rms_z.values())
        if self.joint_dof:
            joint = (f"summed joint chi-square {self.joint:.0f} for {self.joint_dof} degrees of freedom "
                     f"(95 % band {self.joint_band[0]:.0f}-{self.joint_band[1]:.0f}: "
                     f"{'in band' if self.joint_in_band else 'OUT of band'})")
        else:
            joint = "joint chi-square n/a (no run has an invertible covariance)"
        return (f"{self.solver}: RMS of error/sigma {min(values):.2f}-{max(values):.2f}; at {self.runs} runs an "
                f"exact sigma gives each in {lo:.2f}-{hi:.2f} (95 %); outside: {out} ({len(self.outside)}, "
                f"{self.expected_outside:.1f} expected by chance, P = {self.outside_p:.2f}); {joint}")


def consistency(rows: pd.DataFrame, level: float = LEVEL) -> list[Consistency]:
    """Per solver: the per-parameter band check of the RMS of error/sigma and the joint chi-square test of a
    Monte Carlo (the runs of :mod:`studies.montecarlo`; failed runs left out)."""
    from scipy import stats

    ok = rows[rows["failed"] == ""] if "failed" in rows else rows
    out = []
    for solver, part in ok.groupby("solver", sort=False):
        runs = int(part["seed"].nunique())
        if runs < 2:
            continue
        z = part["error"].astype(float) / part["sigma"].astype(float)
        rms_z = {name: float(np.sqrt(np.mean(np.square(v)))) for name, v in z.groupby(part["parameter"], sort=False)}
        band = rms_ratio_band(runs, level)
        outside = [name for name, r in rms_z.items() if not band[0] <= r <= band[1]]
        chance = 1.0 - level
        per_run = part.groupby("seed")["chi_square"].first().to_numpy(float)
        per_run = per_run[np.isfinite(per_run)]
        dof = len(rms_z) * len(per_run)
        out.append(Consistency(solver, runs, rms_z, band, outside, chance * len(rms_z),
                               float(stats.binom.sf(len(outside) - 1, len(rms_z), chance)),
                               float(np.sum(per_run)) if len(per_run) else float("nan"), dof,
                               chi_square_band(dof, level) if dof else (float("nan"), float("nan"))))
    return out
