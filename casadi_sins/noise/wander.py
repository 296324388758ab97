"""Bias instability from a fit's residuals: restricted maximum likelihood of random effects, in closed form.

The model, reduced to the ``k`` error contrasts that can show it: ``e ~ N(0, I + sum_t s_t^2 G_t)``,
``G_t`` the contrasts' covariance under a unit term ``t`` (the accelerometers' or the gyros' wander,
or the competing acceleration constant in each static segment).  Error contrasts are the whitened
data projected off the estimated parameters, so their likelihood is the restricted (REML) one
(Harville 1974) and no parameter is fitted again.

* The NLP (:meth:`BiasWander.from_responses`): the residuals, the Jacobian and the bias responses
  (:mod:`noise.pieces`) whitened under the model without instability; projected off the Jacobian's
  span, one eigen-decomposition of their Gram matrix gives the contrasts, ``k`` at most the number of
  response columns plus one.
* The ILS (:meth:`BiasWander.from_covariances`): its equations whitened by their white-noise
  covariance, ``G_t`` their covariance under a unit instability.

A likelihood for any sizes costs one Cholesky factor (:meth:`BiasWander.nll`); one size with the
others held costs one eigen-decomposition, after which the likelihood is a sum over eigenvalues,
``0.5 sum_i [ln(1 + s^2 l_i) - c_i^2 s^2 l_i / (1 + s^2 l_i)]`` against none
(:meth:`BiasWander.profile`): the searches cost no filter pass and no difference of large terms.
"""

from __future__ import annotations

import dataclasses

import numpy as np

#: Search ranges (SI): accelerometer wander (m/s^2), gyro wander (rad/s), and the competing acceleration
#: constant in each static segment (m/s^2).
WANDER_RANGES = {"accel": (1e-9, 1e-3), "gyro": (1e-13, 1e-5), "segment": (1e-9, 1e-2)}
#: Grid of the search in ln(size), refined by golden section to :data:`SEARCH_TOLERANCE`.
SEARCH_POINTS = 25
SEARCH_TOLERANCE = 0.02
#: 2 ln L below the best at the one-sided 95 % upper bound (chi-square with 1 degree of freedom, 90 %).
UPPER_BOUND_LR = 2.71
#: Rounds of the coordinate search while two terms show.
ROUNDS = 3
#: Directions of the unit-scaled responses below this share of their Gram matrix are dropped (rounding: the
#: sum of a sensor axis' pieces is a bias, in the span of the Jacobian).
GRAM_FLOOR = 1e-12
#: A size above this fraction of the search range's top is at its ceiling.
CEILING_FRACTION = 0.99


@dataclasses.dataclass
class SensorWander:
    """The bias instability of one sensor as the static data show it.

    Attributes
    ----------
    sigma : float
        Restricted maximum likelihood size (steady-state 1 sigma; m/s^2 or rad/s), 0 when none shows.
    lr : float
        Its likelihood ratio against none, ``2 ln L(sigma) / L(0)``.
    upper : float
        One-sided 95 % upper bound (``inf`` when the data do not bound it).
    tau : float
        The correlation time assumed, s.
    included : bool
        It entered the noise model.
    mismatch : bool
        Left out because an acceleration constant in each static segment fits the misfit better
        (model mismatch, left to the checks).
    at_ceiling : bool
        The size is at the top of the search range: the data set it no limit (flagged in the warning).
    cost : float
        When included: the largest factor by which it widened the sensor's bias sigma (1 when not included).
    """

    sigma: float
    lr: float
    upper: float
    tau: float
    included: bool = False
    mismatch: bool = False
    at_ceiling: bool = False
    cost: float = 1.0


def exponential_kernel(times: np.ndarray, tau: float) -> np.ndarray:
    """Correlation ``exp(-|t_i - t_j| / tau)`` of a first-order Gauss-Markov process at ``times``."""
    return np.exp(-np.abs(times[:, None] - times[None, :]) / tau)


def segment_kernel(segments: np.ndarray) -> np.ndarray:
    """Correlation of a term constant in each static segment and independent between segments."""
    return (segments[:, None] == segments[None, :]).astype(float)


def _root(kernel: np.ndarray) -> np.ndarray:
    """``F`` with ``F F^T = kernel`` (eigen-decomposition: the kernel may be singular)."""
    w, v = np.linalg.eigh(kernel)
    return v * np.sqrt(np.clip(w, 0.0, None))


def _off_the_span(basis: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Coordinates ``Y`` (k, c) of ``columns`` projected off the span of the orthonormal ``basis``, in an
    orthonormal basis of what is left (``Y^T Y`` = the projected columns' Gram matrix; directions the
    columns hardly reach dropped).  The columns are scaled to unit length first: gyro responses are 1e5
    times the accelerometers' in SI."""
    norms = np.linalg.norm(columns, axis=0)
    norms[norms == 0.0] = 1.0
    unit = columns / norms
    along = basis.T @ unit
    gram = unit.T @ unit - along.T @ along
    w, v = np.linalg.eigh(0.5 * (gram + gram.T))
    keep = w > GRAM_FLOOR * max(float(w.max()), 1.0)
    return (v[:, keep] * np.sqrt(w[keep])).T * norms


class Profile:
    """The restricted likelihood along one term's size, the others held: eigenvalues ``l`` and squared
    contrasts ``c^2`` in the eigenbasis (module docstring)."""

    def __init__(self, eigenvalues: np.ndarray, squares: np.ndarray, bounds: tuple[float, float]):
        self.eigenvalues, self.squares, self.bounds = eigenvalues, squares, bounds

    def delta(self, size) -> np.ndarray:
        """Negative log-likelihood at ``size`` (scalar or array) minus that at 0."""
        x = np.multiply.outer(np.square(size), self.eigenvalues)
        return 0.5 * np.sum(np.log1p(x) - self.squares * x / (1.0 + x), axis=-1)

    def best(self) -> float:
        """The restricted maximum likelihood size in the search range (0 when none beats 0)."""
        grid = np.linspace(*np.log(self.bounds), SEARCH_POINTS)
        values = self.delta(np.exp(grid))
        i = int(np.argmin(values))
        if values[i] >= 0.0:
            return 0.0
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
        golden = (np.sqrt(5.0) - 1.0) / 2.0
        while hi - lo > SEARCH_TOLERANCE:
            a, b = hi - golden * (hi - lo), lo + golden * (hi - lo)
            if self.delta(np.exp(a)) < self.delta(np.exp(b)):
                hi = b
            else:
                lo = a
        best = float(np.exp(0.5 * (lo + hi)))
        return best if self.delta(best) < values[i] else float(np.exp(grid[i]))

    def lr(self, size: float) -> float:
        """Likelihood ratio ``2 ln L(size) / L(0)`` (0 or more)."""
        return max(0.0, -2.0 * float(self.delta(size)))

    def upper(self, size: float) -> float:
        """One-sided 95 % upper bound: the size above ``size`` where ``2 ln L`` has fallen by
        :data:`UPPER_BOUND_LR` (``inf`` when it does not within the search range)."""
        floor = float(self.delta(size)) + UPPER_BOUND_LR / 2.0
        lo, hi = np.log(max(size, self.bounds[0])), np.log(self.bounds[1])
        if self.delta(np.exp(hi)) < floor:
            return float("inf")
        for _ in range(12):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.delta(np.exp(mid)) < floor else (lo, mid)
        return float(np.exp(hi))


class BiasWander:
    """Restricted likelihood of bias instability as random effects, in closed form (module docstring).

    Parameters
    ----------
    contrasts : (k,) ndarray
        The whitened error contrasts ``e``.
    gram : dict
        Term -> ``G_t`` (k, k), the contrasts' covariance under a unit term.
    tau : float
        The correlation time assumed, s (reported with the estimate).
    """

    def __init__(self, contrasts: np.ndarray, gram: dict[str, np.ndarray], tau: float):
        self.contrasts, self.gram, self.tau = np.asarray(contrasts, dtype=float), gram, float(tau)
        self._alone: dict[str, Profile] = {}

    @classmethod
    def from_responses(cls, rw: np.ndarray, basis: np.ndarray, zw: np.ndarray, pieces, tau: float) -> "BiasWander":
        """From the NLP's whitened residuals ``rw``, an orthonormal ``basis`` of its whitened Jacobian's columns
        (the fit's left singular vectors) and the whitened bias responses ``zw`` with their
        :class:`noise.pieces.BiasPiece` columns: a wander per sensor (Gauss-Markov between the pieces, each
        axis independent) and the competing acceleration per static segment (the accelerometer pieces)."""
        reduced = _off_the_span(basis, np.column_stack([zw, rw]))
        responses, contrasts = reduced[:, :-1], reduced[:, -1]
        sensor = np.array([x.sensor for x in pieces])
        axis = np.array([x.axis for x in pieces])
        times = np.array([x.time for x in pieces])
        segment = np.array([x.segment for x in pieces])
        gram = {}
        for term, source in (("accel", "accel"), ("gyro", "gyro"), ("segment", "accel")):
            factors = []
            for a in range(3):
                sel = np.flatnonzero((sensor == source) & (axis == a))
                if len(sel):
                    kernel = segment_kernel(segment[sel]) if term == "segment" else exponential_kernel(times[sel], tau)
                    factors.append(responses[:, sel] @ _root(kernel))
            if factors:
                c = np.hstack(factors)
                gram[term] = c @ c.T
        return cls(contrasts, gram, tau)

    @classmethod
    def from_covariances(cls, design: np.ndarray, rhs: np.ndarray, units: dict[str, np.ndarray],
                         tau: float) -> "BiasWander":
        """From whitened equations (``design`` (m, p), ``rhs`` (m,)) and their whitened covariances under
        a unit term (``units``: term -> (m, m))."""
        p = design.shape[1]
        q = np.linalg.qr(design / np.linalg.norm(design, axis=0), mode="complete")[0]
        contrast = q[:, p:]  # orthonormal, orthogonal to the design
        return cls(contrast.T @ rhs, {t: contrast.T @ g @ contrast for t, g in units.items()}, tau)

    def covariance(self, sigma: dict[str, float]) -> np.ndarray:
        """The contrasts' covariance ``I + sum_t s_t^2 G_t`` (``sigma``: term -> size; missing terms 0)."""
        return np.eye(len(self.contrasts)) + sum(sigma.get(t, 0.0) ** 2 * g for t, g in self.gram.items())

    def nll(self, sigma: dict[str, float]) -> float:
        """Negative restricted log-likelihood under ``sigma`` (term -> size), up to a constant: one Cholesky
        factor."""
        chol = np.linalg.cholesky(self.covariance(sigma))
        y = np.linalg.solve(chol, self.contrasts)
        return float(np.sum(np.log(np.diag(chol))) + 0.5 * y @ y)

    def profile(self, term: str, sigma: dict[str, float]) -> Profile:
        """The likelihood along ``term``'s size with the other terms of ``sigma`` held."""
        held = {t: s for t, s in sigma.items() if t != term and s > 0.0}
        if not held and term in self._alone:
            return self._alone[term]
        if held:
            chol = np.linalg.cholesky(self.covariance(held))
            inverse = np.linalg.solve(chol, np.eye(len(chol)))
            b, y = inverse @ self.gram[term] @ inverse.T, inverse @ self.contrasts
        else:
            b, y = self.gram[term], self.contrasts
        w, v = np.linalg.eigh(0.5 * (b + b.T))
        out = Profile(np.clip(w, 0.0, None), (v.T @ y) ** 2, WANDER_RANGES[term])
        if not held:
            self._alone[term] = out
        return out

    def estimate(self, terms) -> dict[str, SensorWander]:
        """Each term's restricted maximum likelihood size, its likelihood ratio against none and its 95 %
        upper bound, every other term at its own estimate (coordinate search, :data:`ROUNDS` rounds while
        two or more terms show)."""
        terms = [t for t in terms if t in self.gram]
        sigma = {t: 0.0 for t in terms}
        for _ in range(ROUNDS):
            for term in terms:
                sigma[term] = self.profile(term, sigma).best()
            if sum(s > 0.0 for s in sigma.values()) < 2:
                break
        out = {}
        for term in terms:
            profile = self.profile(term, sigma)
            out[term] = SensorWander(sigma[term], profile.lr(sigma[term]), profile.upper(sigma[term]), self.tau,
                                     at_ceiling=sigma[term] >= CEILING_FRACTION * profile.bounds[1])
        return out
