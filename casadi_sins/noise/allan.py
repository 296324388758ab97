"""Overlapping Allan variance of long records in bounded memory, and the estimate's own uncertainty.

With ``theta_k`` the angle after ``k`` samples (the summed increments) and ``tau = m dt``, the overlapping
estimate (IEEE Std 952-1997, eq. C.10; ``allantools.oavar``) is::

    avar(m) = sum_k (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2 / (2 tau^2 K),     K = n - 2m terms

An 8 h recording at 400 Hz has 11.5 million samples: its angle at every sample is never held.  Instead

* short cluster times are summed while the samples stream past (:class:`StreamingAllan`: a pyramid of
  block sums of 1, 2, 4, ... samples, cluster times of 2 and 3 blocks at every level, starts on the level's
  grid; it holds a few values per level);
* the samples are summed into blocks of ``B`` (:class:`BlockSums`, ``B`` doubling whenever more than
  :data:`MAX_BLOCKS` blocks are held), and longer cluster times ``m = j B`` use starts ``k`` on the block
  grid (:func:`overlapping_avar` of the blocks' angle).

Starts ``s`` samples apart instead of every one make the same estimator with slightly fewer degrees of
freedom once the cluster time spans a few ``s`` (the estimates of neighbouring starts are nearly the same),
and each is exactly ``allantools.oavar`` of the block means.

The estimate's uncertainty follows from the noise model (:mod:`noise.terms`): ``d_k`` are jointly Gaussian
with covariance ``c(h) = -1/2 sum_delta W_delta D((h + delta) g)`` (``D`` the angle's structure function,
``W = (1, -4, 6, -4, 1)`` at ``delta = -2j .. 2j``), so ``var(sum d_k^2) = 2 sum_|h|<K (K - |h|) c(h)^2``
(:func:`estimate_variance`).  Its equivalent degrees of freedom ``2 avar^2 / var`` give the confidence
interval ``avar nu / chi2(nu)`` (:func:`confidence_interval`); beyond ``|h| = 2j`` only the Gauss-Markov term
correlates, geometrically, and its tail is summed in closed form.  For white noise this is the textbook
count (Greenhall's ``edf`` for overlapping estimates; checked against ``allantools`` in the tests).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .terms import AxisTerms, structure

#: Levels of the streamed pyramid: cluster times 1, 2, 3, 4, 6, 8, 12, ... up to 3 * 2^(levels - 1) samples.
SHORT_LEVELS = 8
#: Most blocks held; beyond, neighbouring blocks are summed in pairs (the block doubles).
MAX_BLOCKS = 1 << 20
#: Cluster times per decade beyond the short ones.
PER_DECADE = 10
#: A long cluster time spans at least this many of its starts' spacing (the blocks summed in powers of two).
STARTS_PER_SPAN = 8
#: Lags summed one by one in :func:`estimate_variance`; beyond, a trapezoid over as many.
EXACT_LAGS = 4000
#: The confidence of the bands (one sigma, as allantools gives them).
BAND = 0.6827

#: Weights of the second difference's autocovariance at lags -2j, -j, 0, j, 2j.
_W = np.array([1.0, -4.0, 6.0, -4.0, 1.0])


class StreamingAllan:
    """Overlapping Allan variance sums at short cluster times, fed with increments chunk by chunk.

    A pyramid of block sums of ``2^k`` samples (``k`` up to ``levels - 1``): at level 0 the cluster times of
    1, 2 and 3 samples, at level ``k`` of 2 and 3 blocks (``2^(k+1)``, ``3 2^k`` samples), every start on the
    level's grid (:func:`overlapping_avar` of the level's blocks; ``allantools.oavar`` of the block means).
    Each level holds the angle at its last seven boundaries; the work is about twice one pass over the data.

    Parameters
    ----------
    width : int
        Number of axes (columns of the increments).
    levels : int
        Levels of the pyramid: cluster times up to ``3 2^(levels - 1)`` samples.
    """

    def __init__(self, width: int, levels: int = SHORT_LEVELS):
        self.levels = int(levels)
        self._spans = [(1, 2, 3)] + [(2, 3)] * (self.levels - 1)
        self._sums = [np.zeros((len(j), width)) for j in self._spans]
        self._counts = [np.zeros(len(j), dtype=np.int64) for j in self._spans]
        self._tails = [np.zeros((1, width)) for _ in range(self.levels)]  # angle at the last boundaries (first: 0)
        self._partial = [np.zeros((0, width)) for _ in range(self.levels)]  # a level's increments not yet paired

    def add(self, increments: np.ndarray) -> None:
        """Sum the terms that end within these increments (rows: samples, in order)."""
        x = increments
        for level in range(self.levels):
            if level:  # this level's blocks: the previous level's in pairs
                x = np.concatenate([self._partial[level], x]) if len(self._partial[level]) else x
                pairs = len(x) // 2
                self._partial[level] = x[2 * pairs:].copy()
                x = x[0:2 * pairs:2] + x[1:2 * pairs:2]
            if not len(x):
                break
            self._level_add(level, x)

    def _level_add(self, level: int, x: np.ndarray) -> None:
        tail = self._tails[level]  # the last boundaries, the last at 0 (second differences ignore a constant)
        new = len(tail)
        angle = np.empty((new + len(x), x.shape[1]))
        angle[:new] = tail
        np.cumsum(x, axis=0, out=angle[new:])
        end = len(angle)
        for i, j in enumerate(self._spans[level]):
            first = max(new, 2 * j)  # index of the last point of the first new term
            if first >= end:
                continue
            d = angle[first:end] - angle[first - j:end - j]
            d -= angle[first - j:end - j]
            d += angle[first - 2 * j:end - 2 * j]
            self._sums[level][i] += np.einsum("ij,ij->j", d, d)
            self._counts[level][i] += len(d)
        self._tails[level] = angle[-7:] - angle[-1]

    def result(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(tau (K,), avar (K, width), terms (K,), spacing (K,))`` of the cluster times with at least one term."""
        rows = []
        for level, spans in enumerate(self._spans):
            g = dt * 2**level
            for i, j in enumerate(spans):
                if self._counts[level][i]:
                    tau = j * g
                    rows.append((tau, self._sums[level][i] / (2.0 * tau**2 * self._counts[level][i]),
                                 self._counts[level][i], g))
        rows.sort(key=lambda r: r[0])
        if not rows:
            return np.zeros(0), np.zeros((0, self._sums[0].shape[1])), np.zeros(0, dtype=np.int64), np.zeros(0)
        tau, avar, terms, spacing = zip(*rows)
        return np.array(tau), np.array(avar), np.array(terms), np.array(spacing)


class BlockSums:
    """Sums of consecutive samples over blocks of ``size``, chunk by chunk; with ``limit`` the block doubles
    (neighbouring sums added in pairs) whenever more than ``limit`` blocks are held."""

    def __init__(self, width: int, size: int = 1, limit: int | None = None):
        self.size, self.limit = int(size), limit
        self._parts: list[np.ndarray] = []
        self._held = 0
        self._partial = np.zeros(width)
        self._partial_count = 0

    def add(self, increments: np.ndarray) -> None:
        """Add samples (rows, in order)."""
        x = increments
        while len(x):
            if self._partial_count or len(x) < self.size:  # fill the block begun
                take = x[:self.size - self._partial_count]
                self._partial += take.sum(axis=0)
                self._partial_count += len(take)
                x = x[len(take):]
                if self._partial_count == self.size:
                    block = self._partial[None, :].copy()
                    self._partial[:] = 0.0
                    self._partial_count = 0
                    self._append(block)
                continue
            whole = len(x) // self.size * self.size
            blocks = x[:whole].copy() if self.size == 1 else x[:whole].reshape(-1, self.size, x.shape[1]).sum(axis=1)
            x = x[whole:]
            self._append(blocks)

    def _append(self, blocks: np.ndarray) -> None:
        """Keep complete blocks (no block begun); double the block while more than the limit are held."""
        self._parts.append(blocks)
        self._held += len(blocks)
        while self.limit is not None and self._held > self.limit:
            held = self.sums
            pairs = len(held) // 2
            merged = held[0:2 * pairs:2] + held[1:2 * pairs:2]
            if len(held) % 2:  # the odd block is the first half of the next one
                self._partial = held[-1].copy()
                self._partial_count = self.size
            self.size *= 2
            self._parts, self._held = [merged], len(merged)

    @property
    def sums(self) -> np.ndarray:
        """The complete blocks' sums, ``(count, width)``."""
        if len(self._parts) > 1:
            self._parts = [np.concatenate(self._parts)]
        return self._parts[0] if self._parts else np.zeros((0, len(self._partial)))


def overlapping_avar(increments: np.ndarray, spans, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan variance of increments on a grid of ``spacing`` seconds (samples, or block sums) at
    cluster times of ``spans`` grid steps (module docstring); ``(avar (K, width), terms (K,))``."""
    increments = np.asarray(increments, dtype=float)
    if increments.ndim == 1:
        increments = increments[:, None]
    angle = np.concatenate([np.zeros((1, increments.shape[1])), np.cumsum(increments - increments.mean(axis=0), axis=0)])
    out = np.full((len(spans), increments.shape[1]), np.nan)
    terms = np.zeros(len(spans), dtype=np.int64)
    for i, j in enumerate(int(j) for j in spans):
        if len(angle) <= 2 * j:
            continue
        d = angle[2 * j:] - 2.0 * angle[j:-j] + angle[:-2 * j]
        out[i] = np.einsum("ij,ij->j", d, d) / (2.0 * (j * spacing) ** 2 * len(d))
        terms[i] = len(d)
    return out, terms


def log_spans(first: int, last: int, per_decade: int = PER_DECADE) -> np.ndarray:
    """Whole numbers from ``first`` to ``last``, about ``per_decade`` per decade, evenly on a log scale."""
    if last < first:
        return np.zeros(0, dtype=int)
    count = max(2, int(math.ceil(per_decade * math.log10(max(last, 1) / max(first, 1)))) + 1)
    return np.unique(np.round(np.geomspace(first, last, count)).astype(int))


@dataclasses.dataclass
class AllanCurve:
    """Overlapping Allan variance of the axes of a recording.

    Attributes
    ----------
    tau : ndarray (K,)
        Cluster times, s.
    avar : ndarray (K, width)
        The estimates, (unit/s)^2.
    terms : ndarray (K,)
        Number of second differences summed at each.
    spacing : ndarray (K,)
        The starts' spacing of each estimate (the sample interval, or the block's), s.
    """

    tau: np.ndarray
    avar: np.ndarray
    terms: np.ndarray
    spacing: np.ndarray

    @property
    def adev(self) -> np.ndarray:
        """The Allan deviation, unit/s."""
        return np.sqrt(self.avar)


def allan_curve(short: StreamingAllan, blocks: BlockSums, dt: float) -> AllanCurve:
    """The Allan variance of a recording: the streamed short cluster times, then the blocks' from the first
    multiple of the block beyond them up to half the record (about :data:`PER_DECADE` per decade).

    A cluster time of ``j`` blocks starts every ``s`` blocks, ``s`` the largest power of two within ``j`` /
    :data:`STARTS_PER_SPAN` (``j`` rounded to a multiple of it): the blocks summed in ``s`` (a pyramid), so that
    each cluster time costs the record over ``s``, not the whole record."""
    tau, avar, terms, spacing = short.result(dt)
    sums = blocks.sums
    block_dt = blocks.size * dt
    first = int(math.floor((tau[-1] if len(tau) else 0.0) / block_dt * (1.0 + 1e-9))) + 1
    rows = []
    merged, stride = sums, 1
    for j in log_spans(first, (len(sums) - 1) // 2):
        while 2 * stride * STARTS_PER_SPAN <= j and len(merged) >= 2:  # the next level of the pyramid
            pairs = len(merged) // 2
            merged, stride = merged[0:2 * pairs:2] + merged[1:2 * pairs:2], 2 * stride
        span = max(1, int(round(j / stride)))
        value, count = overlapping_avar(merged, [span], stride * block_dt)
        last = rows[-1][0] if rows else (tau[-1] if len(tau) else 0.0)
        if count[0] and span * stride * block_dt > last * (1.0 + 1e-9):
            rows.append((span * stride * block_dt, value[0], count[0], stride * block_dt))
    if rows:
        long_tau, long_avar, long_terms, long_spacing = (np.array(v) for v in zip(*rows))
    else:
        long_tau, long_avar = np.zeros(0), np.zeros((0, sums.shape[1]))
        long_terms, long_spacing = np.zeros(0, dtype=np.int64), np.zeros(0)
    return AllanCurve(np.concatenate([tau, long_tau]), np.vstack([avar, long_avar]),
                      np.concatenate([terms, long_terms]), np.concatenate([spacing, long_spacing]))


def estimate_variance(model: AxisTerms, span: int, spacing: float, terms: int) -> tuple[float, float]:
    """Expectation and variance of the overlapping Allan variance estimate at ``span`` grid steps of
    ``spacing`` seconds from ``terms`` second differences, under ``model`` (module docstring)."""
    j, n, g = int(span), int(terms), float(spacing)
    tau = j * g
    deltas = np.array([-2, -1, 0, 1, 2]) * j

    def continuous(h):  # c(h) without the quantization's jump at lag 0 of D
        t = (h[:, None] + deltas[None, :]) * g
        d = structure(t, model.white, 0.0, model.gm_sigma, model.gm_tau)
        return -0.5 * d @ _W

    top = min(2 * j, n - 1)
    if top <= EXACT_LAGS:
        h = np.arange(top + 1)
        weights = np.where(h == 0, 1.0, 2.0) * (n - h)
        window = float(np.sum(weights * continuous(h) ** 2))
    else:  # c(h) is smooth between its kinks at 0, j, 2j: a trapezoid through them
        h = np.unique(np.concatenate([np.linspace(0, top, EXACT_LAGS).round(), [j, top]])).astype(np.int64)
        h = h[h <= top]
        f = np.where(h == 0, 1.0, 2.0) * (n - h) * continuous(h) ** 2
        window = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(h)) + 0.5 * (f[0] + f[-1]))
    # the quantization: c gains 6 Q^2, -4 Q^2, Q^2 at lags 0, j, 2j
    q2 = model.quantization**2
    if q2 > 0:
        for lag, jump in ((0, 6.0), (j, -4.0), (2 * j, 1.0)):
            if lag <= top:
                c = float(continuous(np.array([lag]))[0])
                window += (1.0 if lag == 0 else 2.0) * (n - lag) * ((c + jump * q2) ** 2 - c**2)
    tail = _gauss_markov_tail(model, j, g, n) if top == 2 * j else 0.0
    c0 = float(continuous(np.array([0]))[0]) + 6.0 * q2
    return c0 / (2.0 * tau**2), 2.0 * (window + tail) / (4.0 * tau**4 * n**2)


def _gauss_markov_tail(model: AxisTerms, j: int, g: float, n: int) -> float:
    """``2 sum_{h > 2j} (n - h) c(h)^2`` of the Gauss-Markov term: ``c(h) = -sigma^2 T^2 (1 - r^j)^4 r^(h - 2j)``."""
    if model.gm_sigma <= 0.0 or not math.isfinite(model.gm_tau):
        return 0.0
    x = g / model.gm_tau
    amplitude = model.gm_sigma**2 * model.gm_tau**2 * (-math.expm1(-j * x)) ** 4
    count = n - 1 - 2 * j  # lags 2j + u, u = 1 .. count, weight (count + 1 - u)
    if count <= 0:
        return 0.0
    if count <= 100_000:
        u = np.arange(1, count + 1)
        return float(2.0 * amplitude**2 * np.sum((count + 1 - u) * np.exp(-2.0 * x * u)))
    q = math.exp(-2.0 * x)
    one_minus_q = -math.expm1(-2.0 * x)
    if one_minus_q * count < 1e-3:
        return float(2.0 * amplitude**2 * q * count * (count + 1) / 2.0)
    geometric = -math.expm1(-2.0 * x * count) / one_minus_q  # (1 - q^count) / (1 - q)
    return float(2.0 * amplitude**2 * q * (count - q * geometric) / one_minus_q)


def confidence_interval(avar: np.ndarray, dof: np.ndarray, level: float = BAND) -> tuple[np.ndarray, np.ndarray]:
    """The ``level`` interval of Allan variances estimated with ``dof`` equivalent degrees of freedom (a
    chi-square of ``dof``; arrays of one shape): ``(low, high)``."""
    from scipy.special import gammaincinv  # the chi-square quantile: 2 gammaincinv(dof / 2, p)
    avar = np.asarray(avar, dtype=float)
    dof = np.maximum(np.broadcast_to(np.asarray(dof, dtype=float), avar.shape), 1e-3)
    upper, lower = (2.0 * gammaincinv(dof / 2.0, 0.5 + sign * level / 2.0) for sign in (1.0, -1.0))
    return avar * dof / upper, avar * dof / lower
