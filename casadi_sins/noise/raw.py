"""Noise from the raw pulses, independent of any fit: third differences of block sums, and Allan deviation.

In every static segment the increments are summed into blocks of ``m`` samples and
third-differenced.  A bias, a slow drift and a swaying base (periods of seconds) vanish in third
differences of short blocks (physics pitfall 9); what is left has the variance
``20 m s^2 + 70 s_e^2``: white noise (``s`` per sample) grows with the block, quantization
(``s_e``) does not.  A weighted line over ``m = 1, 2, 4, ...`` separates them.  Blocks long enough for
sway or drift to show are dropped (the line stops fitting).  Bias instability with correlation times
of minutes cannot be seen in segments of a minute or two: it comes from a datasheet or stays zero,
which the report says.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..data.recording import Recording
from ..model.noise import SensorNoise
from ..nav.navigation import compensated_increments

#: Block sizes (samples) tried by the raw estimate, and the longest block (s).
BLOCK_SIZES = (1, 2, 4, 8, 16, 32, 64, 128, 256)
MAX_BLOCK_S = 3.0
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


def estimate_sensor_noise(rec: Recording, params) -> RawNoise:
    """Noise of every sensor axis from the static segments' raw pulses (see the module docstring).

    ``params`` only sets the pulse sizes (the scale factors); nothing is fitted.
    """
    segments = [rec.segment_samples(s) for s in rec.static_segments]
    dtheta, dv = zip(*(compensated_increments(rec, params, sl) for sl in segments)) if segments else ((), ())
    white, quant, used = {}, {}, {}
    max_block = max(1, int(MAX_BLOCK_S * rec.rate_hz))
    for sensor, increments in (("gyro", list(dtheta)), ("accel", list(dv))):
        blocks = np.array([m for m in BLOCK_SIZES if m <= max_block], dtype=float)
        var, count = third_difference_variances(increments, blocks.astype(int))
        ok = count > 0
        blocks, var, count = blocks[ok], var[ok], count[ok]
        per_axis_white, per_axis_quant = [], []
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
            # V = 20 m s^2 + 70 s_e^2 -> density s / sqrt(dt), quantization s_e
            s2, s2_err = coef[0] / 20.0, err[0] / 20.0
            e2, e2_err = coef[1] / 70.0, err[1] / 70.0
            density = math.sqrt(s2 / rec.dt)
            density_err = (s2_err / (2.0 * math.sqrt(s2)) if s2 > 0 else math.sqrt(s2_err)) / math.sqrt(rec.dt)
            per_axis_white.append(TermEstimate(density, density_err))
            per_axis_quant.append(TermEstimate(math.sqrt(e2), e2_err / (2.0 * math.sqrt(e2)) if e2 > 0
                                               else math.sqrt(e2_err)))
        white[sensor], quant[sensor], used[sensor] = per_axis_white, per_axis_quant, blocks
    return RawNoise(white, quant, used, sum(sl.stop - sl.start for sl in segments))


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
