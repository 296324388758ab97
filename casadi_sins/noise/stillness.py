"""Is a long record really at rest?  Motion, a bump or a counter glitch, found in its one-second means.

A unit at rest reads a constant rate (the Earth rate and the bias, gravity and the bias) plus its noise
and a slow wander; any motion reads far more.  Per axis, over windows of a second (:mod:`noise.rest`):

* the scatter of the window means, from their successive differences (``1.4826 MAD / sqrt(2)``: a wander of
  minutes does not enter; never below one pulse per window, a counter's step);
* a **spike**: a window mean further than :data:`SPIKE_SIGMAS` scatters from the median of the minute
  around it (a turn, handling, a shock, a counter glitch);
* a **step**: the medians of the half-minutes before and after a window differing by more than
  :data:`STEP_SIGMAS` times their difference's spread (the unit set down in another attitude).

Thresholds are far beyond noise and slow wander (a Gauss-Markov bias of three times its Allan floor at a
correlation time of 100 s moves a half-minute median by a fraction of one scatter): what is found is
motion, told by time and axis.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..data.recording import PULSE_COLUMNS

#: A window mean this many scatters from its minute's median is motion.
SPIKE_SIGMAS = 25.0
#: Half-minute medians this many spreads apart are a step.
STEP_SIGMAS = 12.0
#: Windows on either side of a window (the median of the minute around it; a half-minute for steps).
HALF_SPAN = 30


@dataclasses.dataclass(frozen=True)
class Motion:
    """Where a record at rest moved: the window's start (s from the first sample), the axis, what was seen."""

    start_s: float
    end_s: float
    axis: str
    text: str


def find_motion(window_means: np.ndarray, window_s: float, samples_per_window: int,
                columns=PULSE_COLUMNS) -> Motion | None:
    """The first motion in a record's window means ``(W, axes)`` (pulses per sample, windows of ``window_s``
    seconds and ``samples_per_window`` samples), or None."""
    means = np.asarray(window_means, dtype=float)
    count = len(means)
    if count < 5:
        return None
    steps = np.diff(means, axis=0)
    scatter = 1.4826 * np.median(np.abs(steps - np.median(steps, axis=0)), axis=0) / np.sqrt(2.0)
    scatter = np.maximum(scatter, 1.0 / samples_per_window)  # one pulse in a window
    span = min(HALF_SPAN, (count - 1) // 2)
    padded = np.pad(means, ((span, span), (0, 0)), mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * span + 1, axis=0)
    local = np.median(windows, axis=-1)
    spike = np.abs(means - local) / scatter
    found = []
    if spike.max() > SPIKE_SIGMAS:
        k, axis = _first(spike > SPIKE_SIGMAS)
        found.append((k, axis, f"{columns[axis]} reads {means[k, axis]:.6g} pulses per sample, "
                               f"{spike[k, axis]:.3g} times its scatter from the {means[k, axis] - local[k, axis]:+.3g} "
                               "around it"))
    if count >= 2 * span + 2 and span >= 5:
        half = np.median(np.lib.stride_tricks.sliding_window_view(means, span, axis=0), axis=-1)  # (count-span+1, axes)
        jump = half[span:] - half[:-span]  # median after window k+span minus before it
        spread = 1.2533 * scatter * np.sqrt(2.0 / span)
        step = np.abs(jump) / spread
        if step.max() > STEP_SIGMAS:
            k, axis = _first(step > STEP_SIGMAS)
            run = np.flatnonzero(step[k:, axis] <= STEP_SIGMAS)
            stop = k + (int(run[0]) if len(run) else len(step) - k)
            # where in the run: the largest difference of the half-minutes' means (a peak, where the medians' is flat)
            total = np.concatenate([[0.0], np.cumsum(means[:, axis])])
            starts = np.arange(k, stop)
            mean_jump = (total[starts + 2 * span] - total[starts + span]) - (total[starts + span] - total[starts])
            k = int(starts[np.argmax(np.abs(mean_jump))])
            found.append((k + span, axis, f"{columns[axis]} steps by {jump[k, axis]:+.3g} pulses per sample between "
                                          f"the half-minutes around it ({step[k, axis]:.3g} times their spread)"))
    if not found:
        return None
    k, axis, text = min(found)
    return Motion(k * window_s, (k + 1) * window_s, columns[axis], text)


def _first(mask: np.ndarray) -> tuple[int, int]:
    """The first row, and its first column, where ``mask`` holds."""
    rows = np.flatnonzero(mask.any(axis=1))
    k = int(rows[0])
    return k, int(np.flatnonzero(mask[k])[0])
