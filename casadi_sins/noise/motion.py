"""Base motion: angular sway of the base in the static segments, beyond the gyro noise.

In a static segment the gyro-integrated angle, less its straight line, wanders only by the angle
random walk; a sway of the base shows as an excess at periods of seconds.  Its variance enters the
noise of the static gyro means (:mod:`noise.kalman`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.units import ARCSEC
from ..data.recording import Recording
from ..model.noise import SensorNoise
from ..nav.navigation import compensated_increments

#: Window lengths (s) at which the wander of the gyro angle is compared with its noise.
SWAY_WINDOWS_S = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
#: A sway is reported when its variance is this many standard errors above zero and adds at least
#: this fraction to the noise variance of a static gyro mean.
SWAY_SIGNIFICANCE = 6.0
SWAY_RELEVANCE = 0.1


@dataclasses.dataclass
class SegmentMotion:
    """The base's angular motion in one static segment."""

    segment: int  # segment number
    variance: np.ndarray  # (3,) variance of the base angle about each body axis, rad^2
    amplitude_arcsec: float  # largest axis, sqrt(2 variance): the amplitude of a sinusoid
    period_s: float  # dominant period (from zero crossings of the largest axis), nan when unknown
    significant: bool
    gyro_mean_variance: np.ndarray  # (3,) variance it adds to the segment's mean gyro rate, (rad/s)^2


def base_motion(rec: Recording, params, noise: SensorNoise) -> list[SegmentMotion]:
    """Angular motion of the base in every static segment, beyond the gyro noise.

    The gyro angle over windows of ``w`` seconds changes by ``mean rate x w`` plus noise of variance
    ``arw^2 w + 2 q^2``; a sway of variance ``V`` adds up to ``2 V``.  The excess over the noise, at
    the window where it is largest, estimates ``2 V``; ``V`` adds ``2 V / T^2`` to the variance of the
    segment's mean rate (the angle at both ends of a segment of ``T`` seconds).
    """
    model = noise.complete()
    out = []
    for seg in rec.static_segments:
        sl = rec.segment_samples(seg)
        dtheta, _ = compensated_increments(rec, params, sl)
        n = len(dtheta)
        duration = n * rec.dt
        theta = np.concatenate([np.zeros((1, 3)), np.cumsum(dtheta - dtheta.mean(axis=0), axis=0)])
        best = np.zeros(3)
        best_z = np.zeros(3)
        for window in SWAY_WINDOWS_S:
            m = int(round(window * rec.rate_hz))
            if m < 1 or n < 4 * m:
                continue
            d = theta[m:] - theta[:-m]
            observed = np.mean(d**2, axis=0)
            expected = model.gyro_arw**2 * m * rec.dt + 2.0 * model.gyro_quantization**2
            independent = max(n / m, 1.0)
            excess = observed - expected
            z = excess / (np.maximum(expected, 1e-300) * np.sqrt(2.0 / independent))  # under "no sway"
            better = excess > best
            best = np.where(better, excess, best)
            best_z = np.where(better, z, best_z)
        variance = np.maximum(best, 0.0) / 2.0
        gyro_mean_var = 2.0 * variance / duration**2
        noise_var = (model.gyro_arw**2 * duration + 2.0 * model.gyro_quantization**2) / duration**2
        significant = bool(np.any((best_z > SWAY_SIGNIFICANCE) & (gyro_mean_var > SWAY_RELEVANCE * noise_var)))
        axis = int(np.argmax(variance))
        wander = theta[:, axis] - np.linspace(theta[0, axis], theta[-1, axis], n + 1)
        crossings = np.count_nonzero(np.diff(np.signbit(wander - wander.mean())))
        period = 2.0 * duration / crossings if crossings >= 4 else float("nan")
        out.append(SegmentMotion(seg.number, variance, math.sqrt(2.0 * variance[axis]) / ARCSEC, period,
                                 significant, gyro_mean_var))
    return out


def describe_motion(motions: list[SegmentMotion]) -> str | None:
    """One sentence about a swaying base (``None`` when the base was still)."""
    moving = [m for m in motions if m.significant]
    if not moving:
        return None
    amp = max(m.amplitude_arcsec for m in moving)
    periods = [m.period_s for m in moving if np.isfinite(m.period_s)]
    period = f", periods around {np.median(periods):.3g} s" if periods else ""
    return (f"the base moved (sway) in {len(moving)} of {len(motions)} static segments: up to "
            f"{amp:.3g} arcsec{period} (segments {', '.join(str(m.segment) for m in moving[:8])}"
            f"{', ...' if len(moving) > 8 else ''})")
