"""The continuous part of a design: how long each static lasts, for a fixed orientation sequence.

The predicted covariance comes from a simulated recording whose number of samples and observations
changes with every dwell time, so it is not a differentiable expression of the durations in the
estimator's graph (which is built per schedule *shape*, :mod:`calibrate.nlp.shape`).  The dwell times
are therefore improved by projected gradient descent with finite-difference gradients: one extra
prediction per static (a step of ``STEP_S``, a few observations), the gradient projected onto the
time budget (the statics' sum is fixed), and a backtracking line search along it, every iterate
projected back onto ``{t_i >= minimum_i, sum t_i = budget}``.  Each prediction costs a fraction of a
second, so a schedule of 20 statics takes a few seconds per iteration.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

#: Finite-difference step of a dwell time (s).
STEP_S = 5.0
#: Largest change of one dwell time in a line search's first trial (s); halved on failure.
FIRST_STEP_S = 40.0


def project(y: np.ndarray, low: np.ndarray, total: float) -> np.ndarray:
    """The nearest point to ``y`` with ``x >= low`` and ``sum(x) = total`` (bisection on the shift)."""
    a, b = float(np.min(y - low)) - total, float(np.max(y)) + total
    for _ in range(100):
        tau = 0.5 * (a + b)
        if np.maximum(low, y - tau).sum() > total:
            a = tau
        else:
            b = tau
    x = np.maximum(low, y - 0.5 * (a + b))
    return x + (total - x.sum()) * (x > low) / max(int((x > low).sum()), 1)


def optimise_dwell(times: np.ndarray, low: np.ndarray, objective: Callable[[np.ndarray], float],
                   iterations: int = 6, progress: Callable[[str], None] | None = None) -> tuple[np.ndarray, float]:
    """Improve the dwell times ``times`` (flat, s) of a schedule under ``objective`` (smaller is better).

    Parameters
    ----------
    times, low : ndarray
        Starting dwell times and their minimum; their sum is kept.
    objective : callable
        Flat dwell times -> criterion value.
    iterations : int
        Gradient steps at most.

    Returns
    -------
    times : ndarray
    value : float
    """
    total = float(times.sum())
    x = project(np.asarray(times, float), low, total)
    f = objective(x)
    for it in range(iterations):
        grad = np.array([(objective(x + STEP_S * e) - f) / STEP_S for e in np.eye(len(x))])
        free = (x > low + 1e-6) | (grad < np.mean(grad))
        direction = -(grad - grad[free].mean()) * free
        if not np.any(direction):
            break
        step = FIRST_STEP_S / float(np.max(np.abs(direction)))
        improved = False
        for _ in range(4):
            trial = project(x + step * direction, low, total)
            value = objective(trial)
            if value < f - 1e-5:
                x, f, improved = trial, value, True
                break
            step *= 0.5
        if progress:
            progress(f"dwell times: iteration {it + 1}, objective {f:+.4f}")
        if not improved:
            break
    return x, f
