"""Noise identification of a record at rest: quantization, white noise and a first-order Gauss-Markov bias per
axis, with their uncertainties, by the likelihood of the data's periodograms.

Why a likelihood and not a line through the Allan deviation: the overlapping Allan variances at
neighbouring cluster times share most of their data (at ``tau`` and ``1.26 tau`` they are correlated by
about 0.9 for white noise), and at long ``tau`` each has a few degrees of freedom and a skewed distribution; a weighted
fit that takes them as independent counts the same data many times and gives uncertainties several times
too small, and a fit with their full covariance still treats chi-square variables of three degrees of
freedom as Gaussian.  The periodogram ordinates at the Fourier frequencies are instead independent, each
exponential about its expectation, so their likelihood (Whittle's) is the data's own, up to terms that
vanish with the record's length; taking the *expected periodogram* of the finite record instead of the
spectrum (the "debiased Whittle" likelihood of Sykulski et al., Biometrika 106, 2019) removes the
leakage bias at the lowest frequencies, where a correlation time of a tenth of the record is seen.  The
estimates are then asymptotically efficient, and the inverse Fisher information, or the profile of the
likelihood, gives honest intervals.  The Allan deviation is kept for what it is good at: the picture,
with the fitted terms' lines and bands of the estimates' own spread (:mod:`noise.allan`).

The fit (:func:`fit_axis`), per axis, with ``S = N^2 c_N + Q^2 c_Q + sigma^2 c_GM(T)`` the expectation of
each binned ordinate (:func:`noise.terms.spectrum_columns`):

1. for fixed ``T`` the expectation is linear in ``(N^2, Q^2, sigma^2) >= 0``: the likelihood's maximum by
   Fisher scoring, each step a non-negative weighted least squares with weights ``K / S^2``;
2. the profile likelihood over ``T`` on a grid of :data:`TAU_PER_DECADE` per decade from
   :func:`tau_range`, refined around its maximum;
3. the Gauss-Markov term is *detected* when twice the log-likelihood ratio against no such term exceeds
   :data:`DETECTION` (``T`` exists only under the alternative: the threshold holds the false alarms over
   the grid below one in a thousand);
4. a detected term whose likelihood does not fall by :data:`INTERVAL_LR` towards long correlation times (up
   to ten records) is *not determined*: the record shows only its rising slope (a rate random walk), so
   ``T`` is stated as a lower bound (the lower end of its 95 % interval) and ``sigma`` as at least its value
   there; an undetected term is bounded from above, the largest ``sigma`` with ``2 ln LR`` below
   :data:`UPPER_LR` at any ``T`` up to :data:`TAU_FRACTION` of the record (a longer one is a constant bias
   to a record of that length);
5. uncertainties: the inverse Fisher information at the estimate (one sigma), the 95 % interval of ``T``
   from the profile (:data:`INTERVAL_LR`); a term at zero gets its one-sided 95 % upper bound;
6. a check: the ordinates over the fitted expectation, pooled in thirds of a decade of frequency, are gamma
   variables of mean 1 and shape ``K`` (the ordinates pooled); a band whose tail probability is that of a
   normal beyond :data:`CHECK_LIMIT` says the model misses something (a flicker floor, a vibration line, a
   drift).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .allan import AllanCurve
from .spectrum import Periodogram
from .terms import AxisTerms
from .whittle import (Ordinates, crossing, fisher_information, fit_linear, golden_maximum,
                      inverse_information)

#: Twice the log-likelihood ratio for the Gauss-Markov term (p about 0.001 over the grid of T).
DETECTION = 13.8
#: Twice the log-likelihood drop of a one-sided 95 % upper bound, and of a two-sided 95 % interval.
UPPER_LR = 2.71
INTERVAL_LR = 3.84
#: Normal quantile of a one-sided 95 % bound from a standard error.
ONE_SIDED_95 = 1.645
#: The quantization is stated as fitted when its variance is this many standard errors above zero (else bounded).
SIGNIFICANT = 2.0
#: Correlation times beyond this fraction of the record are weakly determined (said so), and an undetected
#: term is bounded up to it.
TAU_FRACTION = 0.2
#: Correlation times tried per decade, and every how many of them an undetected term is bounded.
TAU_PER_DECADE = 12
BOUND_STEP = 3
#: A counter's axis is fitted where its known quantization's power is below this share of the white noise's,
#: if at least this many bins remain.
COUNTER_SHARE = 0.1
MIN_ORDINATES = 50
#: The spectral check: bands of this fraction of a decade, and the largest |z| taken as a fit.
CHECK_BANDS_PER_DECADE = 3
CHECK_LIMIT = 5.0


@dataclasses.dataclass
class Estimate:
    """One fitted quantity of one axis (in the data's unit).

    Attributes
    ----------
    value : float
        The estimate (for a bound: the bound).
    sigma : float or None
        Its one-sigma standard error (None when a bound).
    low, high : float or None
        A 95 % interval (None where unbounded).
    kind : str
        ``"fitted"``, ``"upper bound"`` (95 %, one-sided), ``"lower bound"`` or ``"none"`` (nothing to state).
    """

    value: float
    sigma: float | None = None
    low: float | None = None
    high: float | None = None
    kind: str = "fitted"

    def scaled(self, factor: float) -> "Estimate":
        """In another unit (times ``factor``)."""
        def times(v):
            return None if v is None else v * factor
        return Estimate(self.value * factor, times(self.sigma), times(self.low), times(self.high), self.kind)

    def as_dict(self) -> dict:
        """For the JSON report."""
        return {"value": self.value, "sigma": self.sigma, "low_95": self.low, "high_95": self.high, "kind": self.kind}


@dataclasses.dataclass
class SpectralCheck:
    """The largest departure of the ordinates from the fitted expectation over bands of frequency."""

    z: float  # signed, in standard errors
    frequency_hz: float  # the band's middle
    ratio: float  # observed over expected power in that band

    @property
    def passed(self) -> bool:
        """Within :data:`CHECK_LIMIT`."""
        return abs(self.z) <= CHECK_LIMIT


@dataclasses.dataclass
class AxisFit:
    """The noise terms of one axis (data's unit: pulses, or rad / m/s after a scale).

    Attributes
    ----------
    terms : AxisTerms
        The fitted model drawn and used downstream (the Gauss-Markov term only when detected and determined).
    white, quantization, gm_sigma, gm_tau : Estimate
        Each term with its uncertainty or bound (module docstring).
    likelihood_ratio : float
        Twice the log-likelihood ratio of the Gauss-Markov term against none.
    status : str
        The Gauss-Markov term: ``"determined"``, ``"tau beyond reach"`` (detected, its correlation time beyond
        :data:`TAU_FRACTION` of the record) or ``"not detected"``.
    rate_random_walk : float
        ``sigma sqrt(2 / T)`` of the fitted term, unit/s/sqrt(s): what a record shorter than ``T`` shows.
    check : SpectralCheck
    profile : ndarray (G, 2)
        ``(T, 2 ln L relative to the maximum)`` over the grid.
    """

    terms: AxisTerms
    white: Estimate
    quantization: Estimate
    gm_sigma: Estimate
    gm_tau: Estimate
    likelihood_ratio: float
    status: str
    rate_random_walk: float
    check: SpectralCheck
    profile: np.ndarray

    def scaled(self, factor: float) -> "AxisFit":
        """In another unit: amplitudes times ``factor`` (a scale factor, unit per pulse)."""
        return dataclasses.replace(self, terms=self.terms.scaled(factor), white=self.white.scaled(factor),
                                   quantization=self.quantization.scaled(factor),
                                   gm_sigma=self.gm_sigma.scaled(factor), rate_random_walk=self.rate_random_walk * factor)


def tau_range(duration: float, dt: float) -> tuple[float, float]:
    """Correlation times tried: from a second (at least 20 samples) to ten records."""
    return max(1.0, 20.0 * dt), 10.0 * duration


def _root(variance: float, variance_sigma: float) -> tuple[float, float]:
    """A standard deviation and its standard error from a variance's."""
    value = math.sqrt(max(variance, 0.0))
    return value, (variance_sigma / (2.0 * value) if value > 0 else math.inf)


def fit_axis(levels: list[Periodogram], axis: int, duration: float, dt: float, counter_pulse: float | None = None
             ) -> AxisFit:
    """Identify the noise terms of one axis from its periodograms (module docstring).

    Parameters
    ----------
    levels : list of Periodogram
        The record's periodograms (:mod:`noise.spectrum`), every axis.
    axis : int
        The column to fit.
    duration : float
        The record's length, s.
    dt : float
        The sample interval, s.
    counter_pulse : float, optional
        The axis is a counter of pulses of this size (integer pulses, remainder carried): its quantization is
        known, ``pulse / sqrt(12)``, but its remainder is a sawtooth, not white (physics pitfall 8).  The fit
        keeps the frequencies where that quantization's power stays below :data:`COUNTER_SHARE` of the white
        noise's (the remainder's fine structure, whatever it is, is bounded by it there).
    """
    data = Ordinates(levels, axis)
    if not np.any(data.power > 0):  # no noise at all (constant pulses)
        zero = Estimate(0.0, 0.0, 0.0, 0.0)
        return AxisFit(AxisTerms(0.0), zero, zero, Estimate(0.0, kind="none"), Estimate(math.nan, kind="none"), 0.0,
                       "not detected", 0.0, SpectralCheck(0.0, math.nan, 1.0), np.zeros((0, 2)))
    if counter_pulse is not None:
        fit = fit_axis(levels, axis, duration, dt)  # white noise and quantization from every frequency first
        q2 = counter_pulse**2 / 12.0
        keep = q2 * data.base[:, 1] <= COUNTER_SHARE * fit.white.value**2 * data.base[:, 0]
        if keep.sum() >= MIN_ORDINATES:
            fit = _fit(data.below(keep), duration, dt)
        known = Estimate(math.sqrt(q2), 0.0, math.sqrt(q2), math.sqrt(q2))
        return dataclasses.replace(fit, quantization=known,
                                   terms=dataclasses.replace(fit.terms, quantization=math.sqrt(q2)))
    return _fit(data, duration, dt)


def _fit(data: "Ordinates", duration: float, dt: float) -> AxisFit:
    """:func:`fit_axis` on the chosen ordinates."""
    null_theta, null_l, null_s = fit_linear(data, data.base)
    lo, hi = tau_range(duration, dt)
    grid = np.geomspace(lo, hi, max(3, int(math.ceil(TAU_PER_DECADE * math.log10(hi / lo))) + 1))
    values, thetas, starts, start = [], [], [], null_s
    for tau in grid:
        theta, value, start = fit_linear(data, data.columns(tau), start=start)
        values.append(value)
        thetas.append(theta)
        starts.append(start)
    values = np.array(values)
    k = int(np.argmax(values))
    tau, theta, best = _refine(data, grid, k, values, thetas, starts[k])
    ratio = max(0.0, 2.0 * (best - null_l))
    reach = TAU_FRACTION * duration
    profile = np.column_stack([grid, 2.0 * (values - best)])
    if ratio > DETECTION and theta[2] > 0.0:
        low, high = _tau_interval(profile, tau)
        if high is not None:
            return _determined(data, tau, theta, ratio, profile, (low, high))
        return _beyond_reach(data, tau, theta, ratio, profile, low or grid[0])
    return _not_detected(data, null_theta, null_s, ratio, profile, reach, grid)


def _refine(data: Ordinates, grid: np.ndarray, k: int, values: np.ndarray, thetas: list, start: np.ndarray):
    """The profile's maximum between the grid's neighbours of its best point."""
    left, right = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    if left == right:
        return grid[k], thetas[k], values[k]

    def value(log_tau):
        return fit_linear(data, data.columns(math.exp(log_tau)), start=start)[1]

    log_tau, best = golden_maximum(value, math.log(left), math.log(right), 1e-3)
    if best <= values[k]:
        return grid[k], thetas[k], values[k]
    tau = math.exp(log_tau)
    theta, value, _ = fit_linear(data, data.columns(tau), start=start)
    return tau, theta, value


def _errors(data: Ordinates, tau: float | None, theta: np.ndarray, expected: np.ndarray) -> np.ndarray:
    """Covariance of ``(N^2, Q^2[, sigma^2, ln T])`` from the Fisher information at the estimate; a variance at
    zero is kept in (its error then bounds it)."""
    derivatives = data.columns(tau)
    if tau is not None:
        h = 1e-4
        d_gm = (data.gm(tau * math.exp(h)) - data.gm(tau * math.exp(-h))) / (2.0 * h)
        derivatives = np.column_stack([derivatives, theta[2] * d_gm])
    return inverse_information(fisher_information(data, derivatives, expected))


def _white_and_quantization(cov: np.ndarray, theta: np.ndarray) -> tuple[Estimate, Estimate]:
    white, white_sigma = _root(theta[0], math.sqrt(max(cov[0, 0], 0.0)))
    q_var_sigma = math.sqrt(max(cov[1, 1], 0.0))
    if theta[1] > SIGNIFICANT * q_var_sigma:
        q, q_sigma = _root(theta[1], q_var_sigma)
        quantization = Estimate(q, q_sigma, q * math.exp(-1.96 * q_sigma / q), q * math.exp(1.96 * q_sigma / q))
    else:  # at or near zero: its one-sided bound
        quantization = Estimate(math.sqrt(max(theta[1], 0.0) + ONE_SIDED_95 * q_var_sigma), kind="upper bound",
                                low=0.0)
    return Estimate(white, white_sigma, white - 1.96 * white_sigma, white + 1.96 * white_sigma), quantization


def _tau_interval(profile: np.ndarray, tau: float) -> tuple[float | None, float | None]:
    """The 95 % profile interval of ``T`` (None where it reaches the grid's end)."""
    grid, drop = profile[:, 0], -profile[:, 1]
    inside = drop <= INTERVAL_LR
    below, above = grid <= tau, grid >= tau

    def crossing(indices):
        for i0, i1 in zip(indices[:-1], indices[1:]):
            if inside[i0] and not inside[i1]:
                t = (INTERVAL_LR - drop[i0]) / (drop[i1] - drop[i0])
                return float(math.exp(math.log(grid[i0]) + t * (math.log(grid[i1]) - math.log(grid[i0]))))
        return None

    low = crossing(np.flatnonzero(below)[::-1])
    high = crossing(np.flatnonzero(above))
    if low is None and not inside[np.flatnonzero(below)].all():
        low = float(grid[np.flatnonzero(below)[-1]])
    return low, high


def _check(data: Ordinates, expected: np.ndarray) -> SpectralCheck:
    """The spectral check of the module docstring: per band the weighted mean of ordinate over expectation, a
    gamma variable of shape ``K`` and mean 1 under the model, its tail probability as a normal ``z``."""
    from scipy.special import gammainc, gammaincc, ndtri
    band = np.floor(np.log10(data.frequency) * CHECK_BANDS_PER_DECADE).astype(int)
    worst = SpectralCheck(0.0, math.nan, 1.0)
    for b in np.unique(band):
        sel = band == b
        k = float(data.weight[sel].sum())
        ratio = float(np.sum(data.weight[sel] * data.power[sel] / expected[sel]) / k)
        tail = gammaincc(k, ratio * k) if ratio >= 1.0 else gammainc(k, ratio * k)
        z = float(-np.sign(ratio - 1.0) * ndtri(max(min(tail, 0.5), 1e-300)))
        if abs(z) > abs(worst.z):
            worst = SpectralCheck(z, float(10 ** ((b + 0.5) / CHECK_BANDS_PER_DECADE)), ratio)
    return worst


def _determined(data, tau, theta, ratio, profile, interval) -> AxisFit:
    expected = data.columns(tau) @ theta
    cov = _errors(data, tau, theta, expected)
    white, quantization = _white_and_quantization(cov, theta)
    sigma, sigma_se = _root(theta[2], math.sqrt(max(cov[2, 2], 0.0)))
    rel = sigma_se / sigma if sigma > 0 else math.inf
    gm_sigma = Estimate(sigma, sigma_se, sigma * math.exp(-1.96 * rel), sigma * math.exp(1.96 * rel))
    tau_se = tau * math.sqrt(max(cov[3, 3], 0.0))
    gm_tau = Estimate(tau, tau_se, *interval)
    terms = AxisTerms(white.value, quantization.value if quantization.kind == "fitted" else 0.0, sigma, tau)
    return AxisFit(terms, white, quantization, gm_sigma, gm_tau, ratio, "determined", sigma * math.sqrt(2.0 / tau),
                   _check(data, expected), profile)


def _beyond_reach(data, tau, theta, ratio, profile, low) -> AxisFit:
    """Detected, but the likelihood does not bound its correlation time from above: ``T`` at least the lower end
    of its 95 % interval, ``sigma`` at least its value there (at longer ``T`` the same rising slope needs a
    larger ``sigma``)."""
    expected = data.columns(tau) @ theta
    cov = _errors(data, None, theta[:2], expected)
    white, quantization = _white_and_quantization(cov, theta)
    at_low, _, _ = fit_linear(data, data.columns(low), start=expected)
    gm_sigma = Estimate(math.sqrt(max(at_low[2], 0.0)), kind="lower bound")
    gm_tau = Estimate(low, kind="lower bound")
    terms = AxisTerms(white.value, quantization.value if quantization.kind == "fitted" else 0.0,
                      math.sqrt(theta[2]), tau)
    return AxisFit(terms, white, quantization, gm_sigma, gm_tau, ratio, "tau beyond reach",
                   math.sqrt(theta[2]) * math.sqrt(2.0 / tau), _check(data, expected), profile)


def _not_detected(data, theta, expected, ratio, profile, reach, grid) -> AxisFit:
    """No Gauss-Markov term: the white noise and quantization alone, and the largest ``sigma`` the record allows
    at any correlation time up to ``reach``."""
    cov = _errors(data, None, theta, expected)
    white, quantization = _white_and_quantization(cov, theta)
    bound, at = 0.0, math.nan
    for tau in grid[grid <= reach][::BOUND_STEP]:
        b = _sigma_upper_bound(data, tau)
        if b > bound:
            bound, at = b, tau
    terms = AxisTerms(white.value, quantization.value if quantization.kind == "fitted" else 0.0)
    return AxisFit(terms, white, quantization, Estimate(bound, low=0.0, kind="upper bound"),
                   Estimate(at, kind="none"), ratio, "not detected", 0.0, _check(data, expected), profile)


def _sigma_upper_bound(data: Ordinates, tau: float) -> float:
    """The largest ``sigma`` at correlation time ``tau`` whose profile likelihood stays within :data:`UPPER_LR` of
    the best."""
    columns = data.columns(tau)
    theta, best, expected = fit_linear(data, columns)
    gm = columns[:, 2]

    def excess(variance):
        _, value, _ = fit_linear(data, data.base, offset=variance * gm, start=expected)
        return 2.0 * (best - value) - UPPER_LR

    info = fisher_information(data, columns, expected)
    spread = math.sqrt(max(inverse_information(info)[2, 2], 0.0))
    low = max(theta[2], 0.0)
    f_low = excess(low)
    high = low + max(spread, 1e-12 * max(np.max(data.power / gm), 1e-300))
    for _ in range(60):
        f_high = excess(high)
        if f_high > 0:
            break
        low, f_low, high = high, f_high, 2.0 * high
    else:
        return math.inf
    return math.sqrt(crossing(excess, low, high, f_low, f_high))


@dataclasses.dataclass
class Identification:
    """The noise of every axis of a record at rest (in the data's unit until scaled).

    Attributes
    ----------
    axes : tuple of str
        The axes' names (``gyro_x`` .. ``accel_z``).
    fits : list of AxisFit
    allan : AllanCurve
        The overlapping Allan variance, (unit/s)^2.
    band : ndarray (2, K, axes)
        The Allan deviation's one-sigma band (:data:`noise.allan.BAND`) from its estimate's equivalent
        degrees of freedom under the fitted model.
    dof : ndarray (K, axes)
        Those degrees of freedom.
    duration : float
        The record's length, s.
    rate_hz : float
    """

    axes: tuple[str, ...]
    fits: list[AxisFit]
    allan: AllanCurve
    band: np.ndarray
    dof: np.ndarray
    duration: float
    rate_hz: float

    def scaled(self, factors) -> "Identification":
        """In another unit per axis: amplitudes times ``factors`` (scale factors, unit per pulse)."""
        factors = np.asarray(factors, dtype=float)
        allan = dataclasses.replace(self.allan, avar=self.allan.avar * factors**2)
        return dataclasses.replace(self, fits=[f.scaled(k) for f, k in zip(self.fits, factors)], allan=allan,
                                   band=self.band * factors)

    def floor(self, axis: int) -> tuple[float, float]:
        """The Allan deviation's minimum of one axis and its cluster time: ``(adev, tau)``."""
        adev = self.allan.adev[:, axis]
        k = int(np.nanargmin(adev))
        return float(adev[k]), float(self.allan.tau[k])


def identify(record, axes=None, progress=None) -> Identification:
    """Identify every axis of a record at rest (:class:`noise.rest.RestRecord`, in pulses: an axis of whole
    pulses is a counter of one pulse, :func:`fit_axis`); ``progress(done, total)`` per axis."""
    from .allan import confidence_interval, estimate_variance
    names = tuple(axes or [f"axis {i}" for i in range(record.allan.avar.shape[1])])
    fits, curve = [], record.allan
    dof = np.zeros_like(curve.avar)
    for i in range(len(names)):
        counter = 1.0 if record.integer[i] else None
        fit = fit_axis(record.periodograms, i, record.duration, record.dt, counter)
        fits.append(fit)
        for k, (tau, spacing, terms) in enumerate(zip(curve.tau, curve.spacing, curve.terms)):
            expected, variance = estimate_variance(fit.terms, int(round(tau / spacing)), spacing, int(terms))
            dof[k, i] = 2.0 * expected**2 / variance if variance > 0 else np.inf
        if progress is not None:
            progress(i + 1, len(names))
    low, high = confidence_interval(curve.avar, np.where(np.isfinite(dof), dof, 1e12))
    return Identification(names, fits, curve, np.sqrt(np.stack([low, high])), dof, record.duration, record.rate_hz)
