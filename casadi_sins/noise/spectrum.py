"""Periodograms of a long record at rest, in bounded memory: what the noise identification fits.

Two views of the same samples, with no frequency counted twice:

* the **block sums** (:class:`noise.allan.BlockSums`, blocks of ``B`` samples, at most a million of them):
  one periodogram over the whole record, from ``1 / T`` up to the blocks' Nyquist frequency ``1 / (2 B dt)``;
  it holds what the Gauss-Markov term and the white noise show;
* the **samples** in segments of :data:`SEGMENT` (:class:`WelchSums`, Bartlett's average of periodograms,
  summed while the samples stream past), used above the blocks' Nyquist frequency only, up to the sampling
  rate's: what the quantization shows.

Every periodogram ordinate ``I_j = |sum_k x_k e^(-i omega_j k)|^2 / n`` at a Fourier frequency is, for a
long record, an exponential variable of mean ``E[I_j]`` (the expectation of :func:`noise.terms.spectrum_columns`
with ``length``), independent of the others; a Bartlett average of ``K`` segments a gamma variable of shape
``K``.  Neighbouring ordinates of the whole-record periodogram are pooled in bins a hundredth of a decade
wide (:func:`binned_periodogram`) where the spectrum hardly changes across a bin: a few thousand bins carry
what a million ordinates do.
"""

from __future__ import annotations

import dataclasses

import numpy as np

#: Samples per segment of the sample-rate periodogram.
SEGMENT = 256
#: Relative width of a bin of the whole-record periodogram (0.01: a hundredth of a frequency).
BIN_WIDTH = 0.01


class WelchSums:
    """Sums of the periodograms of consecutive segments of :data:`SEGMENT` samples, chunk by chunk."""

    def __init__(self, width: int, length: int = SEGMENT):
        self.length = int(length)
        self.sums = np.zeros((self.length // 2 + 1, width))
        self.count = 0
        self._carry = np.zeros((0, width))

    def add(self, increments: np.ndarray) -> None:
        """Add samples (rows, in order)."""
        x = np.concatenate([self._carry, increments]) if len(self._carry) else increments
        whole = len(x) // self.length
        if whole:
            segments = x[:whole * self.length].reshape(whole, self.length, x.shape[1]).transpose(0, 2, 1)
            f = np.fft.rfft(segments, axis=2)
            self.sums += np.einsum("skf,skf->fk", f.real, f.real) / self.length
            self.sums += np.einsum("skf,skf->fk", f.imag, f.imag) / self.length
            self.count += whole
        self._carry = x[whole * self.length:].copy()


@dataclasses.dataclass
class Periodogram:
    """Binned periodogram ordinates of one view of a record (every axis).

    Attributes
    ----------
    omega : ndarray (M,)
        A Fourier frequency of each bin (its middle one), rad per interval.
    weight : ndarray (M,)
        Ordinates pooled in each bin (times the segments averaged): the shape of its gamma distribution.
    power : ndarray (M, width)
        The bin's mean ordinate, (unit)^2 per interval.
    spacing : float
        The interval of the summed increments, s.
    length : int
        The periodogram's number of points (the record's blocks, or a segment's samples).
    """

    omega: np.ndarray
    weight: np.ndarray
    power: np.ndarray
    spacing: float
    length: int

    @property
    def frequency_hz(self) -> np.ndarray:
        """The bins' frequencies, Hz."""
        return self.omega / (2.0 * np.pi * self.spacing)

    def above(self, frequency_hz: float) -> "Periodogram":
        """The bins above a frequency."""
        keep = self.frequency_hz > frequency_hz
        return dataclasses.replace(self, omega=self.omega[keep], weight=self.weight[keep], power=self.power[keep])


def binned_periodogram(sums: np.ndarray, spacing: float, width: float = BIN_WIDTH) -> Periodogram:
    """The periodogram of the whole record's block sums ``(n, axes)``, Fourier frequencies ``1 .. (n - 1) / 2``,
    pooled in bins ``width`` of a frequency wide (single ordinates at the lowest frequencies)."""
    n, axes = sums.shape
    top = (n - 1) // 2
    if top < 1:
        return Periodogram(np.zeros(0), np.zeros(0), np.zeros((0, axes)), spacing, n)
    f = np.fft.rfft(sums - sums.mean(axis=0), axis=0)[1:top + 1]
    ordinates = (f.real**2 + f.imag**2) / n
    # bins [edge_i, edge_i+1) of Fourier indices: single ones up to 1 / width, then geometric steps of 1 + width
    single = int(round(1.0 / width))
    steps = int(np.ceil(np.log((top + 1) / single) / np.log1p(width))) + 1 if top + 1 > single else 0
    edges = np.unique(np.concatenate([np.arange(1, single + 1), np.round(single * (1.0 + width) ** np.arange(steps)),
                                      [top + 1]]).astype(np.int64))
    edges = edges[edges <= top + 1]
    starts, stops = edges[:-1], edges[1:]
    cumulative = np.vstack([np.zeros((1, axes)), np.cumsum(ordinates, axis=0)])
    weight = (stops - starts).astype(float)
    power = (cumulative[stops - 1] - cumulative[starts - 1]) / weight[:, None]
    middle = (starts + stops - 1) // 2
    return Periodogram(2.0 * np.pi * middle / n, weight, power, spacing, n)


def segment_periodogram(welch: WelchSums, dt: float) -> Periodogram:
    """The averaged periodogram of the sample-rate segments, Fourier frequencies ``1 .. L/2 - 1``."""
    length = welch.length
    j = np.arange(1, length // 2)
    if not welch.count:
        return Periodogram(np.zeros(0), np.zeros(0), np.zeros((0, welch.sums.shape[1])), dt, length)
    return Periodogram(2.0 * np.pi * j / length, np.full(len(j), float(welch.count)), welch.sums[j] / welch.count,
                       dt, length)
