"""Segmentation of a session by hand: rests at any orientation joined by free moves (IMU-TK's protocol).

The turntable segmentation (:func:`data.segmentation.detect`) wants rests of 20 s, turns within 8 deg of a
multiple of 90 deg about one body axis and, for the letters' heading, the Earth rate in the gyros.  A session
by hand has none of these, and the calibration needs none: it navigates the measured motion from the gyros
with each group's start attitude free.  So a session by hand is described by its rests alone:

1. rests: from the changes of the signals against each rest's own noise, any offset, slow ends of moves
   excluded (:func:`data.stillness.find_rests`), at least :data:`HAND_REST_S` (a shorter pause is part of a
   move) and what the edges' fit needs (:data:`data.edges.ONSET_REST_S` each side, a few samples besides);
2. the rough sensor models from those rests and the moves between them (:mod:`data.handfit`): the
   accelerometers' ellipsoid gives each rest's gravity direction, the gyros carry it from rest to rest;
3. every rest becomes a static segment without orientation letters, every move between two a rotation without
   nominal axis or angle; a move whose gyro-carried gravity direction misses the next rest's measured one by
   more than :data:`MAX_MISS_DEG` (a jolt, a sensor range exceeded, a rest that was none) ends the group
   there, as handling between groups;
4. a session that cannot be calibrated is refused in one line that says what to add
   (:func:`fit_session`, :func:`too_fast`): too few rests, rests that span too few directions, moves too fast for
   the sample rate.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import InputError
from .edges import ONSET_REST_S
from .handfit import (MAX_STEP_DEG, MIN_HAND_RESTS, MIN_SPREAD_DEG, AccelFit, GyroFit, fit_accelerometers,
                      fit_gyros, spread_deg)
from .recording import Segment
from .stillness import Rests, find_rests

#: A move whose gyro-carried gravity direction misses the next rest's by more than this (deg) is no part of the
#: chain: its group ends there.  A MEMS gyro's noise and g-sensitivity leave well under a degree in a move.
MAX_MISS_DEG = 10.0
#: The shortest rest of a session by hand (s): a pause in a move shorter than this is no rest (IMU-TK takes
#: static intervals of at least 100 samples, a second at 100 Hz).
HAND_REST_S = 1.0


def shortest_hand_rest(rate_hz: float) -> float:
    """The shortest rest of a session by hand (s): :data:`HAND_REST_S`, and at least the onset fit's rest on each
    side and a few samples."""
    return max(HAND_REST_S, 2.0 * ONSET_REST_S + 3.0 / rate_hz)


def rest_means(pulses: np.ndarray, spans) -> tuple[np.ndarray, np.ndarray]:
    """Each rest's mean pulses per sample (K, 3) and its weight, the square root of its samples (K,)."""
    means = np.array([pulses[a:b].mean(axis=0) for a, b in spans])
    return means, np.sqrt(np.array([b - a for a, b in spans], dtype=float))


def fit_session(gyro: np.ndarray, accel: np.ndarray, spans, g: float, dt: float) -> tuple[AccelFit, GyroFit]:
    """The rough accelerometer and gyro models of a session's rests and moves, or the one-line refusal.

    Raises
    ------
    InputError
        Too few rests, rests that span too few directions, moves too fast for the sample rate.
    """
    if len(spans) < MIN_HAND_RESTS:
        raise InputError(None, f"found {len(spans)} rest(s): a session by hand needs at least {MIN_HAND_RESTS} "
                               "rests at different orientations to fit the accelerometers (IMU-TK's protocol: "
                               "30-40 rests of a few seconds, each held still); add rests")
    means, weights = rest_means(accel, spans)
    try:
        accel_fit = fit_accelerometers(means, weights, g, dt)
    except ValueError:
        accel_fit = None
    if accel_fit is None or spread_deg(accel_fit.up) < MIN_SPREAD_DEG or accel_fit.misfit > 0.05 * g:
        spread = "" if accel_fit is None else f" (all within {spread_deg(accel_fit.up):.3g} deg)"
        raise InputError(None, f"the {len(spans)} rests' gravity directions span too few directions{spread}: the "
                               "accelerometers' offsets and scale factors are not determined; add rests with each "
                               "body axis up and down and in between (directions more than "
                               f"{MIN_SPREAD_DEG:g} deg apart)")
    try:
        gyro_fit = fit_gyros(gyro, spans, accel_fit.up)
    except ValueError as exc:
        raise InputError(None, f"{exc}: a session by hand needs moves between its rests") from None
    return accel_fit, gyro_fit


def too_fast(gyro_fit: GyroFit, move_times: list[tuple[float, float]], rate_hz: float) -> str | None:
    """The refusal of moves that turn more than :data:`MAX_STEP_DEG` in one sample, or None."""
    fast = np.flatnonzero(gyro_fit.step_deg > MAX_STEP_DEG)
    if not len(fast):
        return None
    worst = int(fast[np.argmax(gyro_fit.step_deg[fast])])
    step = float(gyro_fit.step_deg[worst])
    where = ", ".join(f"{a:.2f}-{b:.2f} s" for a, b in (move_times[i] for i in fast[:4])) + (
        ", ..." if len(fast) > 4 else "")
    return (f"{len(fast)} move(s) turn more than {MAX_STEP_DEG:g} deg in one sample ({where}; up to {step:.3g} deg, "
            f"{step * rate_hz:.4g} deg/s at {rate_hz:g} Hz): too fast for the sample rate; keep the moves below "
            f"{MAX_STEP_DEG * rate_hz / 2:.4g} deg/s or record at a higher rate")


def detect_handled(time, gyro, accel, rate_hz: float, g: float) -> tuple[list[Segment], list[str]]:
    """The segments of a session by hand (module docstring), and notes on what was found.

    Raises
    ------
    InputError
        No motion, too few rests, rests that span too few directions, moves too fast for the sample rate.
    """
    dt = 1.0 / rate_hz
    shortest = shortest_hand_rest(rate_hz)
    rests: Rests = find_rests(gyro, accel, rate_hz, shortest)
    if not rests.moves:
        raise InputError(None, "no motion in the gyros or accelerometers (only rest, or noise): no schedule of "
                               "rests and moves")
    spans = rests.spans
    accel_fit, gyro_fit = fit_session(gyro, accel, spans, g, dt)
    bounds = [(round(float(time[a] - dt), 9), round(float(time[b - 1]), 9)) for a, b in spans]
    reason = too_fast(gyro_fit, [(bounds[k][1], bounds[k + 1][0]) for k in range(len(bounds) - 1)], rate_hz)
    if reason:
        raise InputError(None, reason)
    notes = [f"{len(spans)} rests at any orientation (from the changes of the signals, any offset; the shortest "
             f"{min(b - a for a, b in spans) * dt:.3g} s), their gravity directions {spread_deg(accel_fit.up):.0f} deg "
             f"apart at most; the gyros carry each into the next within {float(np.max(gyro_fit.miss_deg, initial=0)):.2g} "
             "deg" + (" (the worst moves excepted: see below)" if np.any(gyro_fit.miss_deg > MAX_MISS_DEG) else "")]
    if rests.turning:
        notes.append(f"{len(rests.turning)} quiet stretch(es) turning at a steady rate (their mean rate stands off the "
                     "rests'): taken for motion")
    segments: list[Segment] = []
    group = 1
    for k, (start, end) in enumerate(bounds):
        if k:
            if gyro_fit.miss_deg[k - 1] > MAX_MISS_DEG:
                notes.append(f"{bounds[k - 1][1]:.2f}-{start:.2f} s: the gyros carry gravity into the next rest "
                             f"{gyro_fit.miss_deg[k - 1]:.3g} deg off the measured direction (a jolt, the sensor's "
                             "range exceeded?): taken for handling between groups")
                group += 1
            else:
                segments.append(Segment(len(segments) + 1, group, "rotation", bounds[k - 1][1], start))
        segments.append(Segment(len(segments) + 1, group, "static", start, end))
    return segments, notes

