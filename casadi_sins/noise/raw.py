"""Noise from the raw pulses, independent of any fit: block statistics of the static segments, and Allan deviation.

In every static segment the increments are summed into blocks of ``m`` samples and
third-differenced.  A bias, a slow drift and a swaying base (periods of seconds) vanish in third
differences of short blocks (physics pitfall 9); what is left has the variance
``20 m s^2 + 70 s_e^2``: white noise (``s`` per sample) grows with the block, quantization
(``s_e``) does not.  A weighted line over ``m = 1, 2, 4, ...`` separates them.  Blocks long enough for
sway or drift to show are dropped (the line stops fitting).

A sensor whose pulses are all integers is a counter carrying its remainder (pitfall 8): its
quantization is known, one pulse / sqrt(12) per axis, and block sums cannot show the white noise
beneath a coarse pulse (their differences see the remainder at two instants, undiminished for any
``m``).  For a counter the *accumulated* increments are averaged over blocks of ``m`` samples, up to
16 s, and fourth-differenced instead (:func:`block_mean_variances`, a modified Allan variance)::

    V(m) = (25 m^2 + 35) / (3 m) s^2 + 70 s_e^2 / m

White noise grows with the block, the remainder averages out (a counter's error of the accumulated
increments is bounded), so the white noise shows beneath pulses a thousand times larger once the
blocks last seconds (:func:`white_beneath_quantization`).

Bias instability with correlation times of minutes cannot be seen in segments of a minute or two: it
comes from a datasheet, or from the disagreement between the segments that the solvers measure
(:mod:`calibrate.wander`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..data.recording import Recording
from ..model.noise import SensorNoise
from ..model.registry import ACCEL_SCALE, GYRO_SCALE
from ..nav.navigation import compensated_increments

#: Block sizes (samples) tried by the raw estimate, and the longest block (s).
BLOCK_SIZES = (1, 2, 4, 8, 16, 32, 64, 128, 256)
MAX_BLOCK_S = 3.0
#: Block sizes (samples, powers of two) of a counter's block-mean statistic, and its longest block (s).
MEAN_BLOCK_SIZES = tuple(2**k for k in range(15))
MEAN_MAX_BLOCK_S = 16.0
#: How far a counter's sawtooth may lie from independent remainders in the block-mean statistic, in units of
#: the independent remainders' share ``70 s_e^2 / m`` (measured: up to 5x where the white noise dithers the
#: sawtooth's phase by a few hundredths of a pulse).
QUANTIZATION_SPREAD = 5.0
#: Pulses a block's mean rate must turn a counter's remainder through for its sawtooth to average out in
#: the block (an axis that hardly moves shows a staircase of single pulses instead).
MIN_REMAINDER_CYCLES = 4.0
#: A term of the raw estimate is "determined" when its relative standard error is below this.
DETERMINED = 0.25

@dataclasses.dataclass
class TermEstimate:
    """One noise term of one sensor axis from the raw data."""

    value: float  # SI
    standard_error: float  # SI (of the value)

    @property
    def determined(self) -> bool:
        """The data determine the term (relative standard error below :data:`DETERMINED`)."""
        return self.standard_error <= DETERMINED * max(self.value, 1e-300)

    @property
    def upper_bound(self) -> float:
        """The value plus two standard errors."""
        return self.value + 2.0 * self.standard_error


@dataclasses.dataclass
class RawNoise:
    """The raw-data estimate: per sensor (``"gyro"``, ``"accel"``) and axis, white and quantization terms."""

    white: dict[str, list[TermEstimate]]  # density, rad/sqrt(s) or m/s/sqrt(s)
    quantization: dict[str, list[TermEstimate]]  # rad or m/s
    blocks: dict[str, np.ndarray]  # block sizes used per sensor
    samples: int
    counter: dict[str, bool] = dataclasses.field(default_factory=dict)  # integer pulses: the quantization is known

    def model(self) -> SensorNoise:
        """Determined terms as a :class:`SensorNoise`; undetermined ones left ``None``."""

        def pick(terms):
            return None if not all(t.determined or t.value == 0.0 for t in terms) else np.array([t.value for t in terms])

        return SensorNoise(gyro_arw=pick(self.white["gyro"]), accel_vrw=pick(self.white["accel"]),
                           gyro_quantization=self._quantization("gyro"),
                           accel_quantization=self._quantization("accel"))

    def _quantization(self, sensor: str) -> np.ndarray:
        # the quantization term is bounded well either way: its estimate (or zero) is the model
        return np.array([max(t.value, 0.0) for t in self.quantization[sensor]])

    def upper_bounds(self) -> SensorNoise:
        """The white terms at their upper bounds (for terms the data do not determine)."""
        return SensorNoise(gyro_arw=np.array([t.upper_bound for t in self.white["gyro"]]),
                           accel_vrw=np.array([t.upper_bound for t in self.white["accel"]]),
                           gyro_quantization=self._quantization("gyro"),
                           accel_quantization=self._quantization("accel"))


def third_difference_variances(increments: list[np.ndarray], blocks) -> tuple[np.ndarray, np.ndarray]:
    """Mean square of third differences of block sums, per block size and axis, pooled over segments.

    Block sums of a size twice the previous one are pairs of the previous sums (one pass over the data
    for all the octave-spaced sizes).  Returns ``(variance (len(blocks), 3), count (len(blocks),))``.
    """
    variance = np.zeros((len(blocks), 3))
    count = np.zeros(len(blocks))
    for x in increments:
        x = np.asarray(x, dtype=float)
        sums, size = x, 1
        for b, m in enumerate(int(m) for m in blocks):
            if m == 2 * size:  # n = len(x) // m blocks: the first 2 n sums of the previous size, in pairs
                pairs = len(sums) // 2
                sums = sums[0:2 * pairs:2] + sums[1:2 * pairs:2]
            elif m != size:
                sums = x[: len(x) // m * m].reshape(-1, m, 3).sum(axis=1)
            size = m
            if len(sums) < 8:
                continue
            d3 = np.diff(sums, n=3, axis=0)
            variance[b] += np.sum(d3**2, axis=0)
            count[b] += len(d3)
    done = count > 0
    variance[done] /= count[done][:, None]
    return variance, count


def _fit_line(m: np.ndarray, v: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least squares ``v = slope m + intercept`` (both >= 0); returns values and standard errors."""
    if not np.any(v > 0):  # noise-free data
        return np.zeros(2), np.zeros(2)
    # third differences of neighbouring blocks are correlated: about a third as many independent values
    weights = (count / 3.0) / (2.0 * np.maximum(v, 1e-12 * v.max()) ** 2)
    design = np.column_stack([m, np.ones_like(m)])
    for free in ([0, 1], [0], [1]):
        a = design[:, free]
        info = a.T @ (a * weights[:, None])
        root = np.sqrt(weights)
        coef = np.linalg.lstsq(a * root[:, None], v * root, rcond=None)[0]
        if np.linalg.cond(info) > 1e12:
            info = info + np.eye(len(free)) * 1e-12 * np.trace(info)
        if np.all(coef >= 0):
            out, err = np.zeros(2), np.zeros(2)
            out[free] = coef
            # a misfit beyond the sampling error (e.g. the sawtooth of coarse pulses, not white) widens the errors
            dof = len(v) - len(free)
            misfit = float(np.sum(weights * (v - a @ coef) ** 2) / dof) if dof > 0 else 1.0
            err[free] = np.sqrt(np.diag(np.linalg.inv(info)) * max(misfit, 1.0))
            unfit = [i for i in (0, 1) if i not in free]
            for i in unfit:  # a term pinned at zero: its bound from the other fit
                err[i] = np.sqrt(1.0 / np.sum(weights * design[:, i] ** 2))
            return out, err
    return np.zeros(2), np.sqrt(1.0 / np.array([np.sum(weights * m**2), np.sum(weights)]))


def is_counter(pulses: np.ndarray) -> bool:
    """A sensor's pulses are all integers: a counter carrying its remainder (pitfall 8)."""
    pulses = np.asarray(pulses)
    head = pulses[:1000]  # float pulses show at once: the whole recording is read only for a counter
    if not pulses.size or not np.array_equal(head, np.rint(head)):
        return False
    return bool(np.array_equal(pulses, np.rint(pulses)))


def block_mean_variances(increments: list[np.ndarray], blocks, pulse=None) -> tuple[np.ndarray, np.ndarray]:
    """Mean square of fourth differences of block means of the *accumulated* increments, per block size and
    axis, pooled over segments (module docstring).

    White noise of ``s`` per sample gives ``(25 m^2 + 35) / (3 m) s^2``, independent errors of variance
    ``s_e^2`` of the accumulated increments ``70 s_e^2 / m``; a counter's sawtooth averages out about as
    fast (its cumulative error is bounded).

    Parameters
    ----------
    increments : list of ndarray (n, 3)
        One array per static segment (rad or m/s per sample).
    blocks : sequence of int
        Block sizes, powers of two in increasing order: the means of each size are those of the
        previous size in pairs (one pass over the data for all sizes).
    pulse : ndarray (3,), optional
        A counter's pulse per axis (SI): a segment's axis counts at a block only when its mean rate
        turns the remainder through :data:`MIN_REMAINDER_CYCLES` pulses within the block.

    Returns
    -------
    variance, count : ndarray (len(blocks), 3)
    """
    variance = np.zeros((len(blocks), 3))
    count = np.zeros((len(blocks), 3))
    for x in increments:
        x = np.asarray(x, dtype=float)
        rate = np.abs(x.mean(axis=0)) if len(x) else np.zeros(3)
        means, size = np.cumsum(x, axis=0), 1
        for b, m in enumerate(int(m) for m in blocks):
            while size < m:  # blocks of twice the size: the previous means in pairs
                pairs = len(means) // 2
                means, size = 0.5 * (means[0:2 * pairs:2] + means[1:2 * pairs:2]), 2 * size
            use = np.ones(3, bool) if pulse is None else rate * m >= MIN_REMAINDER_CYCLES * np.asarray(pulse)
            if size != m or len(means) < 6 or not use.any():
                continue
            d4 = np.diff(means, n=4, axis=0)
            variance[b] += np.where(use, np.einsum("ij,ij->j", d4, d4), 0.0)
            count[b] += np.where(use, len(d4), 0)
    done = count > 0
    variance[done] /= count[done]
    return variance, count


def white_beneath_quantization(m: np.ndarray, v: np.ndarray, count: np.ndarray, quantization: float
                               ) -> tuple[float, float]:
    """White noise variance per sample ``s^2`` and its standard error, from :func:`block_mean_variances` of one
    axis beneath a known quantization ``s_e``: weighted least squares of ``v - 70 s_e^2 / m = A(m) s^2``,
    ``A(m) = (25 m^2 + 35) / (3 m)``.

    Each block's weight counts its sampling error and, as a systematic error, :data:`QUANTIZATION_SPREAD`
    times the remainder's share ``70 s_e^2 / m`` (a sawtooth is not independent remainders): blocks where the
    remainder dominates carry no weight.  The longest blocks are dropped (down to three) while they lie far
    above the fit, or while a block lies far *below* the fit's white part, which no remainder can cause
    (sway or drift in the longest blocks carries the fit).
    """
    m = np.asarray(m, dtype=float)
    a = (25.0 * m**2 + 35.0) / (3.0 * m)
    quant = 70.0 * quantization**2 / m
    systematic2 = (QUANTIZATION_SPREAD * quant) ** 2
    # fourth differences of neighbouring blocks are correlated: about a third as many independent values
    independent = np.maximum(count / 3.0, 1.0)
    keep = count > 0
    if not keep.any():
        return 0.0, 0.0  # no block at all (as the line through no block: nothing to weigh)
    while True:
        weights = np.where(keep, 1.0 / (2.0 * np.maximum(v, 1e-300) ** 2 / independent + systematic2), 0.0)
        info = float(np.sum(weights * a**2))
        s2 = max(float(np.sum(weights * a * (v - quant)) / info), 0.0)
        misfit = float(np.sum(weights * (v - quant - a * s2) ** 2)) / max(int(keep.sum()) - 1, 1)
        last = np.flatnonzero(keep)[-1]
        predicted = a[last] * s2 + quant[last]  # the last block's spread as the fit would have it
        above = v[last] - predicted > 4.0 * np.sqrt(2.0 * predicted**2 / independent[last] + systematic2[last])
        below = np.any(keep & (v < a * s2 * (1.0 - 4.0 * np.sqrt(2.0 / independent))))
        if keep.sum() <= 3 or not (above or below):
            return s2, float(np.sqrt(max(misfit, 1.0) / info))
        keep[last] = False


def estimate_sensor_noise(rec: Recording, params) -> RawNoise:
    """Noise of every sensor axis from the static segments' raw pulses (see the module docstring).

    ``params`` only sets the pulse sizes (the scale factors); nothing is fitted.  A counter (:func:`is_counter`)
    has the quantization of one pulse, ``pulse / sqrt(12)`` per axis, and its white noise comes from block
    means (:func:`block_mean_variances`, :func:`white_beneath_quantization`); other sensors' two terms come
    from the line through third differences of block sums (:func:`third_difference_variances`).
    """
    segments = [rec.segment_samples(s) for s in rec.static_segments]
    dtheta, dv = zip(*(compensated_increments(rec, params, sl) for sl in segments)) if segments else ((), ())
    params = np.asarray(params, dtype=float)
    white, quant, used, counter = {}, {}, {}, {}
    for sensor, increments, pulses, scale in (("gyro", list(dtheta), rec.gyro, GYRO_SCALE),
                                              ("accel", list(dv), rec.accel, ACCEL_SCALE)):
        counter[sensor] = is_counter(pulses)
        if counter[sensor]:
            terms, used[sensor] = _counter_terms(increments, np.abs(params[scale]), rec.rate_hz)
        else:
            terms, used[sensor] = _line_terms(increments, rec.rate_hz)
        white[sensor] = [_root(s2, s2_err, math.sqrt(rec.dt)) for s2, s2_err, _ in terms]
        quant[sensor] = [q for _, _, q in terms]
    return RawNoise(white, quant, used, sum(sl.stop - sl.start for sl in segments), counter)


def _counter_terms(increments: list[np.ndarray], pulse: np.ndarray, rate_hz: float):
    """A counter's ``(s^2, its standard error, quantization)`` per axis, and the block sizes."""
    blocks = np.array([m for m in MEAN_BLOCK_SIZES if m <= max(1.0, MEAN_MAX_BLOCK_S * rate_hz)])
    var, count = block_mean_variances(increments, blocks, pulse)
    empty = count.sum(axis=0) == 0
    if empty.any():  # an axis never turned through enough pulses: every block of it, as for independent remainders
        every = block_mean_variances(increments, blocks)
        var[:, empty], count[:, empty] = every[0][:, empty], every[1][:, empty]
    terms = []
    for axis in range(3):
        q = float(pulse[axis]) / math.sqrt(12.0)
        terms.append((*white_beneath_quantization(blocks, var[:, axis], count[:, axis], q), TermEstimate(q, 0.0)))
    return terms, blocks


def _line_terms(increments: list[np.ndarray], rate_hz: float):
    """``(s^2, its standard error, quantization)`` per axis from third differences of block sums, and the blocks."""
    blocks = np.array([m for m in BLOCK_SIZES if m <= max(1, int(MAX_BLOCK_S * rate_hz))], dtype=float)
    var, count = third_difference_variances(increments, blocks.astype(int))
    ok = count > 0
    blocks, var, count = blocks[ok], var[ok], count[ok]
    terms = []
    for axis in range(3):
        keep = np.ones(len(blocks), bool)
        # drop the longest blocks while they lie far above the line (sway, drift)
        while keep.sum() > 3:
            coef, err = _fit_line(blocks[keep], var[keep, axis], count[keep])
            last = np.flatnonzero(keep)[-1]
            predicted = coef[0] * blocks[last] + coef[1]
            spread = var[last, axis] * np.sqrt(6.0 / max(count[last], 1.0))
            if var[last, axis] - predicted <= 4.0 * spread:
                break
            keep[last] = False
        coef, err = _fit_line(blocks[keep], var[keep, axis], count[keep])
        # V = 20 m s^2 + 70 s_e^2 -> s^2 per sample, quantization s_e
        terms.append((coef[0] / 20.0, err[0] / 20.0, _root(coef[1] / 70.0, err[1] / 70.0)))
    return terms, blocks


def _root(variance: float, standard_error: float, per: float = 1.0) -> TermEstimate:
    """A standard deviation (divided by ``per``) and its standard error, from a variance's."""
    if variance > 0:
        return TermEstimate(math.sqrt(variance) / per, standard_error / (2.0 * math.sqrt(variance)) / per)
    return TermEstimate(0.0, math.sqrt(standard_error) / per)


def allan_deviation(rates: list[np.ndarray], dt: float, max_fraction: float = 1.0 / 3.0):
    """Overlapping Allan deviation of rate samples (list of (n, 3) segments), pooled over segments.

    Returns ``(tau (K,), adev (K, 3))`` for octave-spaced cluster times up to ``max_fraction`` of the
    shortest usable segment.
    """
    longest = max((len(r) for r in rates), default=0)
    taus = []
    m = 1
    while m <= longest * max_fraction:
        taus.append(m)
        m *= 2
    out = np.full((len(taus), 3), np.nan)
    for k, m in enumerate(taus):
        total, count = np.zeros(3), 0
        for r in rates:
            if len(r) < 3 * m:
                continue
            theta = np.concatenate([np.zeros((1, 3)), np.cumsum(r, axis=0) * dt])
            d = theta[2 * m:] - 2.0 * theta[m:-m] + theta[: -2 * m]
            total += np.sum(d**2, axis=0)
            count += len(d)
        if count:
            out[k] = np.sqrt(total / count / 2.0) / (m * dt)
    return np.array(taus) * dt, out
