"""Whittle's likelihood of binned periodogram ordinates, and the small solvers the noise identification needs.

Each binned ordinate ``P`` (the mean of ``K`` periodogram ordinates, or of a Bartlett average of ``K``
segments) is a gamma variable of shape ``K`` about its expectation ``S``; the log-likelihood of all of them is,
up to constants (Whittle, 1953; with the expected periodogram of the finite record, the debiased form of
Sykulski et al., Biometrika 106, 2019)::

    ln L = -sum_b K_b (ln S_b + P_b / S_b)

and its Fisher information for parameters ``p`` is ``sum_b K_b (dS_b/dp)(dS_b/dp)^T / S_b^2``.  When ``S`` is
linear in non-negative variances (``S = offset + columns @ theta``), Fisher scoring is a non-negative least
squares weighted by ``K / S^2`` (:func:`fit_linear`), each solved exactly over the supports of a few columns
(:func:`nonnegative_least_squares`); no general optimiser is loaded.
"""

from __future__ import annotations

import math

import numpy as np

from .spectrum import Periodogram
from .terms import gauss_markov_column, spectrum_columns


class Ordinates:
    """The binned ordinates of one axis over every periodogram, with the expectation's columns."""

    def __init__(self, levels: list[Periodogram], axis: int):
        self.levels = [lvl for lvl in levels if len(lvl.omega)]
        self.power = np.concatenate([lvl.power[:, axis] for lvl in self.levels])
        self.weight = np.concatenate([lvl.weight for lvl in self.levels])
        self.base = np.vstack([spectrum_columns(lvl.omega, lvl.spacing, None, lvl.length) for lvl in self.levels])
        self.frequency = np.concatenate([lvl.frequency_hz for lvl in self.levels])
        self.keep = np.ones(len(self.power), dtype=bool)
        self._cache: dict[float, np.ndarray] = {}

    def below(self, keep: np.ndarray) -> "Ordinates":
        """The same ordinates where ``keep`` holds."""
        out = object.__new__(Ordinates)
        out.__dict__.update(self.__dict__)
        out.keep = self.keep.copy()
        out.keep[np.flatnonzero(self.keep)[~keep]] = False
        for name in ("power", "weight", "base", "frequency"):
            setattr(out, name, getattr(self, name)[keep])
        out._cache = {}
        return out

    def gm(self, tau: float) -> np.ndarray:
        """The Gauss-Markov column at correlation time ``tau``."""
        column = self._cache.get(tau)
        if column is None:
            column = np.concatenate([gauss_markov_column(lvl.omega, lvl.spacing, tau, lvl.length)
                                     for lvl in self.levels])[self.keep]
            if len(self._cache) < 512:
                self._cache[tau] = column
        return column

    def columns(self, tau: float | None) -> np.ndarray:
        return self.base if tau is None else np.column_stack([self.base, self.gm(tau)])

    def loglik(self, expected: np.ndarray) -> float:
        """Whittle's log-likelihood (constants dropped)."""
        return float(-np.sum(self.weight * (np.log(expected) + self.power / expected)))


def fit_linear(data: Ordinates, columns: np.ndarray, offset: np.ndarray | float = 0.0,
                start: np.ndarray | None = None, iterations: int = 200) -> tuple[np.ndarray, float, np.ndarray]:
    """Non-negative ``theta`` maximising the likelihood of ``S = offset + columns @ theta`` (Fisher scoring:
    non-negative least squares weighted by ``K / S^2``, halved while the likelihood falls).
    Returns ``(theta, log-likelihood, S)``."""
    floor = 1e-30 * max(float(np.max(data.power)), 1e-300)
    if start is None:
        white = np.median(data.power / columns[:, 0])
        theta = np.zeros(columns.shape[1])
        theta[0] = white
        expected = np.maximum(offset + columns @ theta, floor)
    else:
        expected = np.maximum(start, floor)
        theta = None
    best = -math.inf if theta is None else data.loglik(expected)
    for _ in range(iterations):
        root = np.sqrt(data.weight) / expected
        a = columns * root[:, None]
        norms = np.sqrt(np.sum(a**2, axis=0))
        norms[norms == 0] = 1.0
        proposal = nonnegative_least_squares(a / norms, (data.power - offset) * root) / norms
        step = 1.0
        while True:
            trial = proposal if theta is None else theta + step * (proposal - theta)
            trial_expected = np.maximum(offset + columns @ trial, floor)
            value = data.loglik(trial_expected)
            if value >= best or step < 1e-3:
                break
            step *= 0.5
        gain = value - best
        theta, expected, best = trial, trial_expected, value
        if abs(gain) <= 1e-10 * abs(best) + 1e-9:
            break
    return theta, best, expected


def nonnegative_least_squares(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``argmin |a x - b|`` over ``x >= 0`` for a few columns, exactly: the least squares on every support (from the
    normal equations, the columns being few and scaled), the best of those with no negative part (the optimum is
    one of them)."""
    gram, moment, total = a.T @ a, a.T @ b, float(b @ b)
    columns = a.shape[1]
    best, best_x = total, np.zeros(columns)
    for mask in range(1, 2**columns):
        support = [i for i in range(columns) if mask >> i & 1]
        g, c = gram[np.ix_(support, support)], moment[support]
        try:
            x_s = np.linalg.solve(g, c)
        except np.linalg.LinAlgError:
            continue
        if np.any(x_s < 0):
            continue
        residual = total - float(x_s @ c)  # |a x - b|^2 at the support's least squares
        if residual < best:
            best, best_x = residual, np.zeros(columns)
            best_x[support] = x_s
    return best_x


def golden_maximum(f, low: float, high: float, tolerance: float) -> tuple[float, float]:
    """The maximum of a unimodal ``f`` on ``[low, high]`` by golden sections: ``(x, f(x))``."""
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = high - ratio * (high - low), low + ratio * (high - low)
    fc, fd = f(c), f(d)
    while high - low > tolerance:
        if fc >= fd:
            high, d, fd = d, c, fc
            c = high - ratio * (high - low)
            fc = f(c)
        else:
            low, c, fc = c, d, fd
            d = low + ratio * (high - low)
            fd = f(d)
    return (c, fc) if fc >= fd else (d, fd)


def crossing(f, low: float, high: float, f_low: float, f_high: float, relative: float = 1e-3) -> float:
    """Where an increasing ``f`` crosses zero between ``low`` (``f_low < 0``) and ``high`` (``f_high > 0``), by
    regula falsi with the Illinois step."""
    side = 0
    while high - low > relative * high:
        x = high - f_high * (high - low) / (f_high - f_low)
        fx = f(x)
        if fx < 0:
            low, f_low = x, fx
            if side == -1:
                f_high *= 0.5
            side = -1
        else:
            high, f_high = x, fx
            if side == 1:
                f_low *= 0.5
            side = 1
    return 0.5 * (low + high)


def fisher_information(data: Ordinates, derivatives: np.ndarray, expected: np.ndarray) -> np.ndarray:
    """Fisher information of Whittle's likelihood for the expectation's derivatives ``(M, P)``."""
    w = data.weight / expected**2
    return derivatives.T @ (derivatives * w[:, None])


def inverse_information(info: np.ndarray) -> np.ndarray:
    """The inverse of an information matrix, scaled for conditioning (inf where singular)."""
    d = np.sqrt(np.abs(np.diag(info)))
    d[d == 0] = 1.0
    try:
        inv = np.linalg.inv(info / np.outer(d, d)) / np.outer(d, d)
    except np.linalg.LinAlgError:
        return np.full_like(info, np.inf)
    return inv
