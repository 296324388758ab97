"""Linear motion of the base (a deck's heave and surge): found in the static segments' specific force.

In a static segment the accelerometers read gravity turned by the base's sway, plus the base's
acceleration and their noise.  The sway's part is known from the gyros: the body turns by the
gyro-integrated angle ``theta``, so gravity reads ``f_mean - theta x f_mean`` and the rest,

    a_k = f_k - f_mean + theta_k x f_mean,

is the base's acceleration plus white noise (velocity random walk and the counter's remainder), and a
straight line (the gyros' mean rate, taken out of ``theta``, leaves a ramp of the sway's angle).
Over blocks of :data:`BLOCK_S` its spectrum is flat without motion; a deck puts lines in it at
periods of seconds to tens of seconds.  Their power over the white noise, summed over the segments,
decides that the base moves (:data:`MOTION_SIGNIFICANCE` standard errors); the lines of each
segment (:func:`noise.taper.rate_lines`) give the motion's periods and size, and the bands the
estimator leaves to the base (:func:`motion_bands`).  A session by hand (rests at any orientation) has no base:
its rests' tremor is left to the noise model.

A bounded linear motion has no power at zero frequency: the navigated velocity carries it, and the
estimator gives each static segment a free base velocity within these bands (:mod:`calibrate.nlp.base`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..data.recording import Recording
from ..model.noise import SensorNoise
from ..nav.navigation import compensated_increments
from .taper import SLOWEST_CYCLES, mean_response, motion_floor, rate_lines

#: Block of the specific force (s): lines up to 1 Hz (periods down to 2 s) are told apart.
BLOCK_S = 0.5
#: Periods of base motion (s) counted: seconds to tens of seconds.
PERIODS_S = (2.0, 60.0)
#: The base moves when the specific force's power in :data:`PERIODS_S`, summed over the static segments,
#: is this many standard errors above the white noise's, and at least :data:`MOTION_RELEVANCE` times it (a
#: long recording would find a noise model a few per cent low significant).
MOTION_SIGNIFICANCE = 8.0
MOTION_RELEVANCE = 1.25
#: A line of the base's acceleration smaller than this (m/s^2, 10 ug) moves the base by micrometres per second at
#: these periods: it leaves less than 0.05 ug in a static's tilt, and does not count.
SMALLEST_LINE = 10e-6 * 9.80665


@dataclasses.dataclass(frozen=True)
class MotionLine:
    """A line of the base's acceleration in one static segment."""

    segment: int
    frequency_hz: float
    acceleration: float  # amplitude, m/s^2 (largest body axis)
    vertical: float = 0.0  # amplitude along gravity, m/s^2 (heave)
    horizontal: float = 0.0  # amplitude across it, m/s^2 (surge, sway)

    @property
    def period_s(self) -> float:
        """Period, s."""
        return 1.0 / self.frequency_hz

    @property
    def amplitude(self) -> float:
        """Amplitude of the acceleration along the motion, m/s^2: its parts along and across gravity together (a
        surge at a heading between two body axes is larger than either axis shows)."""
        return max(self.acceleration, float(np.hypot(self.vertical, self.horizontal)))

    @property
    def displacement(self) -> float:
        """Amplitude of the displacement it makes, m."""
        return self.amplitude / (2.0 * np.pi * self.frequency_hz) ** 2

    @property
    def velocity(self) -> float:
        """Amplitude of the velocity it makes, m/s."""
        return self.amplitude / (2.0 * np.pi * self.frequency_hz)


@dataclasses.dataclass
class LinearMotion:
    """The base's linear motion over a recording.

    Attributes
    ----------
    significance : float
        The specific force's power in :data:`PERIODS_S` over the white noise's, in standard errors.
    excess : float
        That power over the noise's (1 without motion).
    lines : list of MotionLine
        The lines of every static segment.
    """

    significance: float
    excess: float
    lines: list[MotionLine]

    @property
    def moving(self) -> bool:
        """Whether the base moves linearly."""
        return self.significance > MOTION_SIGNIFICANCE and self.excess > MOTION_RELEVANCE and bool(self.lines)

    def bands(self, margin_hz: float, join_hz: float = 0.0) -> list[tuple[float, float, str]]:
        """:func:`motion_bands` of the lines, each with the ENU axes its lines move (``"U"`` for heave, ``"EN"``
        across gravity: the heading within a segment is not known here)."""
        out = []
        for low, high in motion_bands([line.frequency_hz for line in self.lines], margin_hz, join_hz):
            inside = [line for line in self.lines if low <= line.frequency_hz <= high]
            axes = ("EN" if any(line.horizontal > SMALLEST_LINE for line in inside) else "") + (
                "U" if any(line.vertical > SMALLEST_LINE for line in inside) else "")
            out.append((low, high, axes or "ENU"))
        return out

    def describe(self) -> str | None:
        """One sentence about the base's linear motion (``None`` when it does not move)."""
        if not self.moving:
            return None
        periods = np.array([line.period_s for line in self.lines])
        strongest = max(self.lines, key=lambda line: line.amplitude)
        return (f"the base moved linearly (heave, surge: a deck or a vehicle): accelerations up to "
                f"{strongest.amplitude / 9.80665 * 1e3:.3g} mg, displacements up to "
                f"{max(line.displacement for line in self.lines) * 100:.3g} cm and velocities up to "
                f"{max(line.velocity for line in self.lines) * 1e3:.3g} mm/s at periods "
                f"{periods.min():.3g}-{periods.max():.3g} s ({self.significance:.3g} standard errors above the "
                f"accelerometer noise)")


def motion_bands(frequencies, margin_hz: float, join_hz: float = 0.0) -> list[tuple[float, float]]:
    """Frequency bands (Hz) that cover ``frequencies`` with ``margin_hz`` on either side, bands that overlap or lie
    within ``join_hz`` of each other merged."""
    bands: list[list[float]] = []
    for f in sorted(frequencies):
        if bands and f - margin_hz <= bands[-1][1] + join_hz:
            bands[-1][1] = f + margin_hz
        else:
            bands.append([f - margin_hz, f + margin_hz])
    return [(max(low, 0.0), high) for low, high in bands]


def base_acceleration(dtheta: np.ndarray, dv: np.ndarray, dt: float, block: int) -> np.ndarray:
    """The base's acceleration in a static segment (module docstring) from compensated increments, per block of
    ``block`` samples (N, 3), body axes, m/s^2: the specific force less gravity turned by the block's mean angle
    (the rotation vector to second order, ``phi' = w + phi x w / 2``: sway rotations do not commute, and the
    summed angle alone carries their slow beat, which gravity would turn into a slow acceleration)."""
    count = len(dv) // block
    force = dv[:count * block].reshape(count, block, 3).sum(axis=1) / (block * dt)
    mean = force.mean(axis=0)
    turns = (dtheta[:count * block] - dtheta[:count * block].mean(axis=0)).reshape(count, block, 3)
    sums = turns.sum(axis=1)
    before = np.cumsum(sums, axis=0) - sums  # the angle at each block's start
    inside = (block - np.arange(block) - 0.5) / block  # a sample's share of the block's mean angle
    angle = before + np.einsum("cbj,b->cj", turns, inside)  # the mean over each block's samples
    angle = angle + np.cumsum(0.5 * np.cross(angle, sums), axis=0)
    return force - mean + np.cross(angle - angle.mean(axis=0), mean)


def detrended(values: np.ndarray) -> np.ndarray:
    """``values`` (N, 3) less their least-squares straight line."""
    ramp = np.column_stack([np.ones(len(values)), np.linspace(-1.0, 1.0, len(values))])
    return values - ramp @ np.linalg.lstsq(ramp, values, rcond=None)[0]


def linear_motion(rec: Recording, params, noise: SensorNoise, increments: dict | None = None) -> LinearMotion:
    """The base's linear motion in the static segments of a recording (module docstring); ``increments``: the
    static segments' compensated increments by segment number (:func:`noise.motion.static_increments`), if at
    hand.  The lines are sought only when the power says the base moves."""
    if any(seg.is_free for seg in rec.segments):
        # rests at any orientation: a unit held or set down by hand has no base; what moves it in a rest is the
        # hand's tremor and settling, which the rests' noise takes (a hand session's rests are seconds long)
        return LinearMotion(0.0, 1.0, [])
    model = noise.complete()
    block = max(1, int(round(BLOCK_S * rec.rate_hz)))
    step = block * rec.dt
    # white noise of a block's mean specific force: velocity random walk, and the counter's remainder at both ends
    white = model.accel_vrw**2 / step + 2.0 * model.accel_quantization**2 / step**2
    power, expected, variance, segments = 0.0, 0.0, 0.0, []
    for seg in rec.static_segments:
        dtheta, dv = (increments[seg.number] if increments is not None
                      else compensated_increments(rec, params, rec.segment_samples(seg)))
        accel = base_acceleration(dtheta, dv, rec.dt, block)
        n = len(accel)
        if n < 32:
            continue
        duration = n * step
        hann = np.hanning(n + 2)[1:-1]
        spectrum = np.abs(np.fft.rfft(hann[:, None] * detrended(accel), axis=0)) ** 2
        noise_bin = np.sum(hann**2) * white  # expected power of a bin of white noise, per axis
        cycles = np.arange(len(spectrum))
        band = (cycles >= max(SLOWEST_CYCLES, duration / PERIODS_S[1])) & (cycles <= duration / PERIODS_S[0])
        power += float(np.sum(spectrum[band] / noise_bin[None, :]))
        expected += 3.0 * band.sum()
        variance += 3.0 * band.sum() * (1.0 + 2.0 / 9.0)  # a Hann spectrum's neighbouring bins correlate
        force = dv.sum(axis=0)
        segments.append((seg.number, accel, duration, force / np.linalg.norm(force)))  # up, in body axes
    if expected == 0.0:
        return LinearMotion(0.0, 1.0, [])
    motion = LinearMotion((power - expected) / np.sqrt(variance), power / expected, [])
    if motion.significance > MOTION_SIGNIFICANCE and motion.excess > MOTION_RELEVANCE:
        density = np.sqrt(white * step)
        for number, accel, duration, up in segments:
            found = rate_lines(accel, motion_floor(len(accel), step, density))
            for f, p, c, s in zip(found.cycles, found.power, found.cosine, found.sine):
                kept = np.sqrt(mean_response(np.array([f / duration]), block, rec.dt)[0])  # what the block's mean kept
                size = float(np.sqrt(2.0 * np.max(p))) / kept
                in_band = SLOWEST_CYCLES <= f and duration / PERIODS_S[1] <= f <= duration / PERIODS_S[0]
                if in_band and size > SMALLEST_LINE:
                    vertical = float(np.hypot(c @ up, s @ up)) / kept
                    horizontal = float(np.hypot(np.linalg.norm(c - (c @ up) * up), np.linalg.norm(s - (s @ up) * up)))
                    motion.lines.append(MotionLine(number, f / duration, size, vertical, horizontal / kept))
    return motion
