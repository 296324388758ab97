"""Whether a misfit of the paper's 21-parameter fit is a term of the output model it leaves out.

When a 21-parameter fit shows a misfit (velocity steps across rotations beyond the static residuals,
a bias wander in the static data, residuals beyond the noise model), the extra groups of the registry
are tried on the same data before the misfit is blamed on a bias instability or on the schedule: the
extended graph (the groups the schedule can see) is linearised at the 21-parameter solution with the
extras at their prior, one generalised least-squares pass under the same noise model fits them, and
each group's Wald statistic is held against the information criterion as ``model="auto"`` does
(:func:`.selection.select_groups`).  The groups that pass are named in a warning with the remedy
(``--model auto`` or ``--model extended``).
"""

from __future__ import annotations

import numpy as np

from ...model.registry import GROUPS, MODELS, N_PARAMS
from .gls import Fit, generalised_least_squares
from .graph import ResidualGraph
from .selection import select_groups


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
    return select_groups(extended, wide.z, wide.covariance_natural)


def evidence_warning(selection: dict, misfit: str) -> str | None:
    """The warning naming the groups that explain a misfit, with the remedy (``None`` when none does)."""
    found = [k for k, v in selection.items() if v["selected"]]
    if not found:
        return None
    named = ", ".join(f"{GROUPS[k].label} ({k}, Wald {selection[k]['statistic']:.3g} > {selection[k]['threshold']:.3g})"
                      for k in found)
    return (f"{misfit} is explained by terms outside the paper's 21 parameters: {named}; calibrate with "
            "--model auto (or --model extended) to estimate them")


def is_21(graph: ResidualGraph) -> bool:
    """Whether a graph fits the paper's 21 parameters alone."""
    return len(graph.names) == N_PARAMS
