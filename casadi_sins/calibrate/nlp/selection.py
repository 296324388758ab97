"""Which extra parameter groups a recording supports: observability, and the information criterion."""

from __future__ import annotations

import numpy as np

from ...model.parameters import CORRELATION_LIMIT
from ...model.registry import DROP_ORDER, GROUPS, MODELS, NAMES, groups_in, model_names
from .graph import ResidualGraph
from .ipopt import RANK_TOLERANCE


def model_groups(model) -> tuple[str, ...]:
    """The extra groups a model argument asks for: ``"21"`` none, ``"extended"`` and ``"auto"`` all of them
    (``"auto"`` selects among them after the fit), or a tuple of group keys."""
    if model in ("21", None):
        return ()
    if model in ("extended", "auto"):
        return MODELS["extended"]
    groups = tuple(model)
    model_names(groups)  # names unknown groups
    return groups


def model_label(names) -> str:
    """``"21-parameter model"`` or ``"model (21 + quadratic, ...)"``."""
    extras = groups_in(names)
    return "21-parameter model" if not extras else f"model (21 + {', '.join(extras)})"


def unobservable_group(graph: ResidualGraph, weights) -> tuple[str, list[str]] | None:
    """The extra group to leave out when the Jacobian at the reference is rank deficient, with the
    variables it is confounded with; ``None`` when every variable is observable."""
    jac = weights @ np.asarray(graph.jacobian(np.zeros(graph.n_variables))[1])
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    null = s < RANK_TOLERANCE * s[0]
    if not null.any():
        return None
    involved = np.abs(vt[null]).max(axis=0) > 0.1
    names = graph.variable_names()
    present = groups_in([n for n, i in zip(names, involved) if i])
    for key in DROP_ORDER:
        if key in present:
            members = set(GROUPS[key].names)
            return key, [n for n, i in zip(names, involved) if i and n not in members]
    return None


def inseparable_group(graph: ResidualGraph, weights) -> tuple[str, str, float] | None:
    """The first extra group (in :data:`model.registry.DROP_ORDER`) the schedule cannot separate from one of
    the 21: ``(group, parameter of the 21, correlation)``; ``None`` when every group is separated.

    A group is inseparable when, with the rest of the model, it explains a parameter of the 21 by more than
    :data:`model.parameters.CORRELATION_LIMIT` (its multiple correlation, from the predicted covariance of the
    weighted Jacobian at the reference): that parameter's sigma then grows more than sevenfold, e.g. the gyro
    scale asymmetry under turns of one sense per axis, one with the scale factor.
    """
    jac = weights @ np.asarray(graph.jacobian(np.zeros(graph.n_variables))[1])
    information = jac.T @ jac
    names = graph.variable_names()
    every = np.arange(len(names))
    covariance = np.linalg.pinv(information)  # a rank the schedule lacks elsewhere is not this question
    core = [i for i, name in enumerate(names) if name in NAMES]
    for key in DROP_ORDER:
        members = {i for i, name in enumerate(names) if name in GROUPS[key].names}
        if not members:
            continue
        rest = np.array([i for i in every if i not in members])
        without = np.linalg.pinv(information[np.ix_(rest, rest)])
        position = {i: k for k, i in enumerate(rest)}
        explained = [1.0 - without[position[i], position[i]] / covariance[i, i] for i in core]
        worst = int(np.argmax(explained))
        correlation = float(np.sqrt(max(explained[worst], 0.0)))
        if correlation > CORRELATION_LIMIT:
            return key, names[core[worst]], correlation
    return None


def select_groups(graph: ResidualGraph, z: np.ndarray, covariance_natural: np.ndarray) -> dict[str, dict]:
    """Which extra groups the data support: each group's Wald statistic ``x^T C^-1 x`` (natural units, from
    the fit with every group) against the Bayesian information criterion ``k ln n``."""
    out = {}
    n = graph.n_residuals
    for key in groups_in(graph.names):
        idx = [graph.names.index(name) for name in GROUPS[key].names]
        x = z[idx]
        cov = covariance_natural[np.ix_(idx, idx)]
        statistic = float(x @ np.linalg.solve(cov, x))
        threshold = len(idx) * float(np.log(n))
        out[key] = {"statistic": statistic, "threshold": threshold, "selected": statistic > threshold,
                    "values_natural": x.tolist()}
    return out
