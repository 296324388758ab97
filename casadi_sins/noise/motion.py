"""Base motion: angular sway of the base in the static segments, beyond the gyro noise.

In a static segment the gyro-integrated angle, less its straight line, wanders only by the angle
random walk; a sway of the base shows as an excess at periods of seconds.  A segment that sways
gets a tapered gyro mean (:mod:`noise.taper`): its window is chosen from the rate of the segment's
gyro-integrated attitude, and the leakage bound enters the noise of the mean (:mod:`noise.kalman`);
a segment without significant sway keeps the plain mean, with the little sway variance it has.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.rotations import euler_to_enu, quat_to_dcm, small_rotations
from ..core.units import ARCSEC, DEG_PER_H
from ..data.recording import Recording
from ..model.noise import SensorNoise
from ..nav.navigation import compensated_increments, navigate_group
from .taper import STEP_S, TaperChoice, choose_taper, window

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
    gyro_mean_variance: np.ndarray  # (3,) variance it adds to the segment's plain mean gyro rate, (rad/s)^2
    taper: TaperChoice | None = None  # a swaying segment's tapered gyro mean (noise.taper)
    reference_arcsec: float = 0.0  # how far the recording's attitude reference turns in the segment
    uses_reference: bool = False  # the tapered mean reads the gyros' attitude against the reference's

    @property
    def added_variance(self) -> np.ndarray:
        """(3,) what the base motion adds to the variance of the segment's gyro mean: the tapered mean's
        leakage bound, or the plain mean's sway variance."""
        return self.taper.leakage if self.taper is not None else self.gyro_mean_variance


def static_increments(rec: Recording, params) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Compensated ``(dtheta, dv)`` of every static segment, by segment number (what the base-motion analyses
    read)."""
    return {seg.number: compensated_increments(rec, params, rec.segment_samples(seg)) for seg in rec.static_segments}


def base_motion(rec: Recording, params, noise: SensorNoise, increments: dict | None = None) -> list[SegmentMotion]:
    """Angular motion of the base in every static segment, beyond the gyro noise.

    The gyro angle over windows of ``w`` seconds changes by ``mean rate x w`` plus noise of variance
    ``arw^2 w + 2 q^2``; a sway adds to it.  The excess over the noise, at the window where it is
    largest, tells whether the base sways (at most ``4 V`` for a sway of variance ``V``, at half its
    period) and bounds what it adds to the variance of the segment's plain mean rate (``2 V / T^2``, the
    angle at both ends of a segment of ``T`` seconds).  Where the base sways, ``V`` itself is the
    variance of the angle less its straight line and the angle random walk in it: the amplitude
    ``sqrt(2 V)`` of a sinusoid (the window statistic alone overstates it by up to ``sqrt 2``).  A segment
    that sways gets a tapered mean (:func:`sway_tapers`).
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
        gyro_mean_var = np.maximum(best, 0.0) / duration**2  # 2 V / T^2 at V = best / 2 (conservative)
        noise_var = (model.gyro_arw**2 * duration + 2.0 * model.gyro_quantization**2) / duration**2
        significant = bool(np.any((best_z > SWAY_SIGNIFICANCE) & (gyro_mean_var > SWAY_RELEVANCE * noise_var)))
        # the sway's own variance where it sways; elsewhere the window statistic's bound of it (2 V <= best)
        variance = _angle_variance(theta, duration, model.gyro_arw) if significant else np.maximum(best, 0.0) / 2.0
        axis = int(np.argmax(variance))
        wander = theta[:, axis] - np.linspace(theta[0, axis], theta[-1, axis], n + 1)
        crossings = np.count_nonzero(np.diff(np.signbit(wander - wander.mean())))
        period = 2.0 * duration / crossings if crossings >= 4 else float("nan")
        out.append(SegmentMotion(seg.number, variance, math.sqrt(2.0 * variance[axis]) / ARCSEC, period,
                                 significant, gyro_mean_var))
    if rec.reference is not None:
        for motion, seg in zip(out, rec.static_segments):
            motion.reference_arcsec = reference_turn(rec, seg) / ARCSEC
            motion.uses_reference = motion.reference_arcsec > REFERENCE_MOTION_ARCSEC
    if any(m.significant or m.uses_reference for m in out):
        sway_tapers(rec, params, model, out)
    return out


def _angle_variance(theta: np.ndarray, duration: float, arw: np.ndarray) -> np.ndarray:
    """(3,) variance of the base angle: the gyro angle's about its least-squares line, less what the angle random
    walk leaves there (``arw^2 T / 15``)."""
    t = np.linspace(0.0, 1.0, len(theta))
    design = np.column_stack([np.ones_like(t), t])
    residual = theta - design @ np.linalg.lstsq(design, theta, rcond=None)[0]
    return np.maximum(np.mean(residual**2, axis=0) - arw**2 * duration / 15.0, 0.0)


#: The recording's attitude reference is read in a static segment where it turns by more than this (arcsec):
#: a still bench's encoders do not move, a master INS on a deck or a settling table does.
REFERENCE_MOTION_ARCSEC = 0.5


def step_ends(n: int, rate_hz: float, step_s: float = STEP_S) -> np.ndarray:
    """The last sample of each step of a static segment of ``n`` samples, as :func:`calibrate.steps.plan_steps`
    cuts it into steps of ``step_s``."""
    count = max(1, int(round(n / max(1, int(round(step_s * rate_hz))))))
    return np.round(np.linspace(0, n, count + 1)).astype(int)[1:] - 1


def attitude_rates(attitude: np.ndarray, rate_hz: float, step_s: float = STEP_S,
                   reference: np.ndarray | None = None) -> np.ndarray:
    """The rate of the gyro-integrated attitude over a static segment's steps after its first (N, 3), body axes
    at the segment's middle, rad/s: the steps of :func:`calibrate.steps.plan_steps` (``step_s`` long), the log
    map of each step's end attitude against the middle one, differenced.  ``attitude`` (n, 4): the navigated
    quaternions after each of the segment's ``n`` samples; ``reference`` (n, 3, 3): an attitude reference's
    matrices (ENU) at the same samples, whose turns are taken off."""
    ends = step_ends(len(attitude), rate_hz, step_s)
    dcm = quat_to_dcm(attitude[ends])
    middle = dcm[len(dcm) // 2]
    psi = small_rotations(dcm, middle)
    if reference is not None:
        psi = psi - small_rotations(reference[ends], reference[ends[len(ends) // 2]])
    return (np.diff(psi, axis=0) / (np.diff(ends)[:, None] / rate_hz)) @ middle


def reference_turn(rec: Recording, segment) -> float:
    """How far (rad) the recording's attitude reference turns within a static segment: the largest angle
    between its attitude at a step's end and at the segment's start."""
    sl = rec.segment_samples(segment)
    attitude = euler_to_enu(rec.reference[sl][step_ends(sl.stop - sl.start, rec.rate_hz)])
    return float(np.max(np.linalg.norm(small_rotations(attitude, attitude[0]), axis=-1)))


def sway_tapers(rec: Recording, params, noise: SensorNoise, motions: list[SegmentMotion]) -> None:
    """The tapered mean of every swaying segment, and of every segment where the recording's attitude reference
    turns (in place): the window of least noise plus leakage for the rate of its gyro-integrated attitude
    (:func:`noise.taper.choose_taper`).  Where the reference turns, the rate less the reference's is tried as
    well, and read when it leaves less: the reference's own noise against the motion it takes off (what its
    tapered mean would have left in the gyros', a motion too slow for the window included)."""
    moving = {m.segment: m for m in motions if m.significant or m.uses_reference}
    density = noise.gyro_arw
    for group in rec.group_ids:
        segments = [s for s in rec.group_segments(group) if s.number in moving]
        if not segments:
            continue
        nav = navigate_group(rec, group, params)
        for seg in segments:
            sl = rec.segment_samples(seg)
            motion = moving[seg.number]
            quats = nav.quaternion[sl.start - nav.samples.start:sl.stop - nav.samples.start]
            rates = attitude_rates(quats, rec.rate_hz)
            if len(rates) < 16:
                motion.uses_reference = False
                continue
            step = (sl.stop - sl.start) * rec.dt / (len(rates) + 1)
            motion.taper = choose_taper(rates, step, density)
            if not motion.uses_reference:
                continue
            reference = euler_to_enu(rec.reference[sl])
            with_reference = choose_taper(attitude_rates(quats, rec.rate_hz, reference=reference), step, density)
            turns = rates - attitude_rates(quats, rec.rate_hz, reference=reference)  # the reference's rate
            left = motion.taper.leakage + reference_motion_variance(turns, step, window(len(rates), motion.taper.nw))
            motion.uses_reference = _total(with_reference, density, step, len(rates)) < _total(
                dataclasses.replace(motion.taper, leakage=left), density, step, len(rates))
            if motion.uses_reference:
                motion.taper = with_reference
            else:
                motion.taper = dataclasses.replace(motion.taper, leakage=left)
            if not motion.significant and not motion.uses_reference:
                motion.taper = None  # a still segment whose reference turns only by its own noise: the plain mean


def reference_motion_variance(turns: np.ndarray, step: float, weights: np.ndarray) -> np.ndarray:
    """(3,) what a reference's turns ``turns`` (rate over steps of ``step``, N x 3) show of the base's motion in a
    tapered mean of ``weights`` (N,): its tapered mean squared, less the share of its own white angle noise
    (from the second differences of its angle)."""
    weights = weights / weights.sum()
    seen = (weights @ turns) ** 2
    angle_noise = np.mean(np.diff(turns, axis=0) ** 2, axis=0) * step**2 / 6.0  # e_k - 2 e_k-1 + e_k-2: 6 sigma^2
    coefficients = np.diff(np.concatenate([[0.0], weights, [0.0]])) / step
    return np.maximum(seen - angle_noise * np.sum(coefficients**2), 0.0)


def _total(choice: TaperChoice, density: np.ndarray, step: float, n: int) -> float:
    """The variance of a tapered mean, summed over the axes: white noise and the leakage bound."""
    return float(np.sum(density**2 * choice.noise_factor / (n * step) + choice.leakage))


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


def sway_treatment(motions: list[SegmentMotion]) -> str:
    """How the gyro means of a swaying base were taken, in a phrase (for the sway warning)."""
    tapered = [m for m in motions if m.taper is not None]
    plain = [m for m in motions if m.significant and m.taper is None]
    parts = []
    if tapered:
        factors = [m.taper.noise_factor for m in tapered]
        leak = max(float(np.sqrt(np.max(m.taper.leakage))) for m in tapered) / DEG_PER_H
        referenced = sum(1 for m in tapered if m.uses_reference)
        against = f", {referenced} of them against the attitude reference" if referenced else ""
        parts.append(f"the gyro means of {len(tapered)} segments are tapered{against} (Slepian window, NW "
                     f"{min(m.taper.nw for m in tapered):g}-{max(m.taper.nw for m in tapered):g}: "
                     f"{min(factors):.3g}-{max(factors):.3g} times a plain mean's noise variance, sway leakage "
                     f"bounded by {leak:.2g} deg/h)")
    if plain:
        parts.append(f"the gyro means of {len(plain)} segments too short to taper carry the sway's variance")
    return "; ".join(parts)
