"""One pass over a long record at rest: everything the noise identification needs, in bounded memory.

The increments (pulses, six axes) stream past once, chunk by chunk (:meth:`RestAccumulator.add`); each
chunk feeds

* the overlapping Allan variance at short cluster times (:class:`noise.allan.StreamingAllan`);
* the block sums (:class:`noise.allan.BlockSums`, at most :data:`noise.allan.MAX_BLOCKS` blocks): the Allan
  variance at longer cluster times and the whole record's periodogram;
* the sample-rate periodogram of short segments (:class:`noise.spectrum.WelchSums`);
* the sums over one-second windows, for the stillness check (:mod:`noise.stillness`).

What is held: a million blocks of six sums (48 MB), the windows (50 bytes per second of record), a segment
and the angle of the longest short cluster time: never the record.  Every chunk's first sample's rate is
taken off the rest as a reference (the Allan variance and the periodograms ignore a constant; the sums
stay small and exact).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .allan import MAX_BLOCKS, AllanCurve, BlockSums, StreamingAllan, allan_curve
from .spectrum import Periodogram, WelchSums, binned_periodogram, segment_periodogram

#: The windows of the stillness check, s.
WINDOW_S = 1.0


@dataclasses.dataclass
class RestRecord:
    """What one pass over a record at rest leaves (see the module docstring).

    Attributes
    ----------
    rate_hz : float
    samples : int
    allan : AllanCurve
        The overlapping Allan variance of the six axes (pulses/s)^2.
    periodograms : list of Periodogram
        The whole record's (block sums) and, above the blocks' Nyquist frequency, the segments'.
    window_means : ndarray (W, 6)
        Mean pulses per sample over consecutive windows of ``window_samples`` samples.
    window_samples : int
    integer : ndarray (6,) of bool
        Whether every pulse of the axis was a whole number (a counter).
    mean_rate : ndarray (6,)
        Mean pulses per sample.
    """

    rate_hz: float
    samples: int
    allan: AllanCurve
    periodograms: list[Periodogram]
    window_means: np.ndarray
    window_samples: int
    integer: np.ndarray
    mean_rate: np.ndarray

    @property
    def dt(self) -> float:
        """The sample interval, s."""
        return 1.0 / self.rate_hz

    @property
    def window_s(self) -> float:
        """The windows' length, s."""
        return self.window_samples / self.rate_hz

    @property
    def duration(self) -> float:
        """The record's length, s."""
        return self.samples / self.rate_hz


class RestAccumulator:
    """The single pass of the module docstring: ``add`` chunks of pulses, then ``result()``."""

    def __init__(self, rate_hz: float, width: int = 6, max_blocks: int = MAX_BLOCKS, expected_samples: int = 0):
        self.rate_hz = float(rate_hz)
        self.width = width
        self.short = StreamingAllan(width)
        size = 1
        while expected_samples > size * max_blocks:  # the block the record will need (it doubles if longer)
            size *= 2
        self.blocks = BlockSums(width, size=size, limit=max_blocks)
        self.welch = WelchSums(width)
        window = max(1, int(round(WINDOW_S * self.rate_hz)))
        self.windows = BlockSums(width, size=window)
        self.samples = 0
        self.integer = np.ones(width, dtype=bool)
        self._reference: np.ndarray | None = None
        self._total = np.zeros(width)

    def add(self, pulses: np.ndarray) -> None:
        """Feed the next samples (rows in time order, one column per axis)."""
        if not len(pulses):
            return
        if self._reference is None:
            self._reference = pulses[0].astype(float).copy()
        self.integer &= np.all(pulses == np.rint(pulses), axis=0)
        x = pulses - self._reference
        self.short.add(x)
        self.blocks.add(x)
        self.welch.add(x)
        self.windows.add(x)
        self._total += x.sum(axis=0)
        self.samples += len(x)

    def result(self) -> RestRecord:
        """The record's statistics (see :class:`RestRecord`)."""
        dt = 1.0 / self.rate_hz
        sums = self.blocks.sums
        block_dt = self.blocks.size * dt
        whole = binned_periodogram(sums, block_dt)
        segments = segment_periodogram(self.welch, dt).above(0.5 / block_dt)
        reference = self._reference if self._reference is not None else np.zeros(self.width)
        return RestRecord(self.rate_hz, self.samples, allan_curve(self.short, self.blocks, dt), [whole, segments],
                          self.windows.sums / self.windows.size + reference, self.windows.size, self.integer.copy(),
                          self._total / max(self.samples, 1) + reference)


def rest_record(increments: np.ndarray, rate_hz: float, chunk: int = 1 << 16) -> RestRecord:
    """The statistics of increments held in memory ``(samples, axes)`` (the Python API's way in; the command
    streams a file instead, :func:`noise.static_run.read_rest`)."""
    increments = np.asarray(increments, dtype=float)
    if increments.ndim == 1:
        increments = increments[:, None]
    acc = RestAccumulator(rate_hz, width=increments.shape[1], expected_samples=len(increments))
    for start in range(0, len(increments), chunk):
        acc.add(increments[start:start + chunk])
    return acc.result()
