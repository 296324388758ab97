"""Whether a misfit of the paper's 21-parameter fit is a term of the output model it leaves out.

When a 21-parameter fit shows a misfit (velocity steps across rotations beyond the static residuals,
a bias wander in the static data, residuals beyond the noise model), the extra groups of the registry
are tried on the same data before the misfit is blamed on a bias instability or on the schedule: the
extended graph (the groups the schedule can see) is linearised at the 21-parameter solution with the
extras at their prior, one generalised least-squares pass under the same noise model fits them, and
each group's Wald statistic is held against the information criterion as ``model="auto"`` does
(:func:`.selection.select_groups`).

A warning with the remedy (``--model auto`` or ``--model extended``) is for a term that matters: its Wald
statistic passes the family-wise threshold over all the groups tried (:data:`FAMILY_ALPHA`, Bonferroni:
chi-square with the group's size at ``1 - alpha / groups``), **and** including it moves some of the 21
by at least :data:`MOVE_FRACTION` of their sigma (the shift ``C_pg C_gg^-1 x_g`` of the extended fit
when the group is left at its prior, against the 21-parameter fit's sigma).  A group that passes the
information criterion but not both of these is stated in a note of the report, not a warning: a term
the data hint at that would change no value of the table beyond its noise (on a paper-conditions
recording a time offset of -7.4 +/- 3.8 us at Wald 8.51 against 8.2 had told the user to recalibrate).
"""

from __future__ import annotations

import numpy as np

from ...model.registry import GROUPS, MODELS, N_PARAMS, NAMES
from .gls import Fit, generalised_least_squares
from .graph import ResidualGraph
from .selection import select_groups


#: Family-wise probability that a unit without any extra term is told to recalibrate with one.
FAMILY_ALPHA = 0.01
#: Including a term must move some of the 21 by this fraction of their sigma to be worth a warning.
MOVE_FRACTION = 0.5


def embed(z: np.ndarray, names: tuple[str, ...], wider: tuple[str, ...]) -> np.ndarray:
    """A decision vector of the parameters ``names`` (then start attitudes) in the model ``wider``: the
    parameters ``wider`` adds at their prior (0 in natural units)."""
    out = np.zeros(len(wider) + len(z) - len(names))
    index = [wider.index(n) for n in names]
    out[index] = z[:len(names)]
    out[len(wider):] = z[len(names):]
    return out


def candidate_groups(use_rotation_steps: bool) -> tuple[str, ...]:
    """The extra groups a fit can see: all, or those that need no velocity step across a rotation."""
    return tuple(g for g in MODELS["extended"] if use_rotation_steps or not GROUPS[g].needs_rotation_steps)


def group_evidence(rec, graph: ResidualGraph, fit: Fit, noise_plan, extended: ResidualGraph, progress=None) -> dict:
    """The Wald statistics of the extra groups of ``extended`` at the 21-parameter fit ``fit`` of ``graph``
    (:func:`.selection.select_groups`: ``{group: {"statistic", "threshold", "selected", ...}}``)."""
    z = embed(fit.z, graph.names, extended.names)
    wide = generalised_least_squares(rec, extended, noise_plan, fit.noise, z, fit.use_rotation_steps, progress,
                                     update_free=False)
    selection = select_groups(extended, wide.z, wide.covariance_natural)
    sigma_21 = np.sqrt(np.diag(fit.covariance_natural)[:N_PARAMS])
    return judge_groups(selection, extended.names, wide.z, wide.covariance_natural, sigma_21)


def family_threshold(size: int, groups: int, alpha: float = FAMILY_ALPHA) -> float:
    """The Wald statistic a group of ``size`` terms must pass when ``groups`` groups are tried together
    (Bonferroni: the chi-square quantile at ``1 - alpha / groups``)."""
    from scipy.stats import chi2  # loaded only when a misfit is examined

    return float(chi2.isf(alpha / max(groups, 1), size))


def moves_of(names, z: np.ndarray, covariance: np.ndarray, group: str, sigma_21: np.ndarray) -> np.ndarray:
    """How far including ``group`` moves each of the 21, in their sigma: ``C_pg C_gg^-1 x_g`` of the fit with
    every group (natural units, ``z`` and ``covariance``) over ``sigma_21`` (the 21-parameter fit's sigma)."""
    idx = [names.index(n) for n in GROUPS[group].names]
    core = [names.index(n) for n in NAMES]
    shift = covariance[np.ix_(core, idx)] @ np.linalg.solve(covariance[np.ix_(idx, idx)], z[idx])
    return np.abs(shift) / sigma_21


def judge_groups(selection: dict, names, z: np.ndarray, covariance: np.ndarray, sigma_21: np.ndarray) -> dict:
    """Each group of ``selection`` (:func:`.selection.select_groups`) judged by its family-wise evidence and
    by what it would change (module docstring): ``"selected"`` becomes both, the information criterion's
    choice is kept as ``"hinted"``, with ``"family_threshold"``, ``"largest_move"`` (sigma) and
    ``"moved"`` (the parameter)."""
    out = {}
    for key, v in selection.items():
        moves = moves_of(list(names), z, covariance, key, sigma_21)
        threshold = family_threshold(len(GROUPS[key].names), len(selection))
        worst = int(np.argmax(moves))
        out[key] = v | {"hinted": v["selected"], "family_threshold": threshold, "largest_move": float(moves[worst]),
                        "moved": NAMES[worst],
                        "selected": bool(v["statistic"] > threshold and moves[worst] >= MOVE_FRACTION)}
    return out


def evidence_warning(selection: dict, misfit: str) -> str | None:
    """The warning naming the groups that explain a misfit, with the remedy (``None`` when none does)."""
    found = [k for k, v in selection.items() if v["selected"]]
    if not found:
        return None
    named = ", ".join(f"{GROUPS[k].label} ({k}, Wald {selection[k]['statistic']:.3g} > "
                      f"{selection[k].get('family_threshold', selection[k]['threshold']):.3g}; it moves "
                      f"{selection[k].get('moved', '?')} by {selection[k].get('largest_move', float('nan')):.2g} sigma)"
                      for k in found)
    return (f"{misfit} is explained by terms outside the paper's 21 parameters: {named}; calibrate with "
            "--model auto (or --model extended) to estimate them")


def evidence_note(selection: dict, misfit: str) -> str | None:
    """The note for groups the data hint at that do not earn a warning (``None`` when there is none)."""
    hinted = [k for k, v in selection.items() if v.get("hinted") and not v["selected"]]
    if not hinted:
        return None
    named = ", ".join(f"{GROUPS[k].label} ({k}, Wald {selection[k]['statistic']:.3g}; family-wise threshold "
                      f"{selection[k]['family_threshold']:.3g}; it would move {selection[k]['moved']} by "
                      f"{selection[k]['largest_move']:.2g} sigma)" for k in hinted)
    return (f"{misfit}: the data hint at terms outside the 21 that do not earn a warning (evidence below the "
            f"family-wise {FAMILY_ALPHA:g} threshold over the groups tried, or a move of the 21 below "
            f"{MOVE_FRACTION:g} sigma): {named}")


def is_21(graph: ResidualGraph) -> bool:
    """Whether a graph fits the paper's 21 parameters alone."""
    return len(graph.names) == N_PARAMS
