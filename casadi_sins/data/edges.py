"""Rest and motion in a recording: moving stretches, the exact edges of the rests, attitude jumps.

:func:`activity` and :func:`find_motions` tell rest from motion by the gyro rate magnitude (see
:mod:`data.segmentation`); :func:`static_stretches` turns them into rests with exact edges, split where
the attitude jumps with no motion at all.

The rate magnitude sees a turn once it is well above the resting noise: a turn of the paper's half-sine profile within 0.02 s, but slow handling with a
minimum-jerk time law (its rate grows like ``t^2``) only after 0.2-0.4 s.  The gyro-integrated angle
is far more sensitive: at rest it follows a straight line (the Earth rate and the bias) plus the
angle random walk, and from the onset ``t0`` it departs like ``c (t - t0)^p`` (``p = 2`` for a turn
starting at a finite angular acceleration, ``p = 3`` for a minimum-jerk start).  :func:`onset` fits
that change point: for every candidate ``t0`` and ``p`` the line (with a slow curvature, a sway's) and
``c`` are least squares over a window reaching from a second of rest into the motion, and the smallest
sum of squares wins.

The static then ends where the fitted departure reaches twice the static's own noise level (the rms
residual of the rest's polynomial) before ``t0``: on the safe side by the onset's uncertainty, less than
half a sample for the paper's turns, at most :data:`MAX_MARGIN_S`.  The same fit mirrored in time finds
where motion ends.  :func:`trim_rest` applies it to stated segment times (``refine``): an edge moves only
when the motion fitted inside the stated rest stands :data:`TRIM_SIGMAS` noise levels clear.

A simulated recording may join two groups with no handling at all: the attitude jumps inside one rest
(a teleport).  The mean specific force's direction (or the Earth rate's, for a turn about the
vertical) changes there in one sample; :func:`jumps` finds such changes by binary segmentation of the
mean, and the rest is split there.
"""

from __future__ import annotations

import dataclasses

import numpy as np

#: Seconds of smoothing of the rate magnitude.
SMOOTH_S = 0.05
#: Below this contrast of the rate magnitude (peak over the resting scatter) nothing turns: the noise of
#: a rest alone reaches a few.
MIN_CONTRAST = 30.0
#: An attitude jump inside a rest: the mean specific force turns by more than this (deg), or the mean gyro
#: rate changes by more than this share of its magnitude; either by this many times the typical step
#: between consecutive 1 s means.
JUMP_FORCE_DEG = 5.0
JUMP_RATE_SHARE = 0.3
JUMP_SIGMAS = 20.0
#: Seconds of rest the change-point fit starts with (more when the fit puts the onset near its start),
#: and seconds it reaches past the point where the rate magnitude is surely above rest.
REST_WINDOW_S = 1.0
PAST_MOTION_S = 0.3
#: Degree of the polynomial the angle follows at rest over the fit's window: a line, and a curvature that
#: takes up a sway's slow wander (which a line would leave to the onset's term).
BASE_DEGREE = 2
#: Exponents of the departure ``c (t - t0)^p`` tried.
EXPONENTS = (2.0, 3.0)
#: Largest safety margin (s) a static keeps from the fitted onset, and how many noise levels it spans.
MAX_MARGIN_S = 0.05
MARGIN_SIGMAS = 2.0
#: The rest the onset fit needs before the motion it fits (s).
ONSET_REST_S = 0.2
#: A stated static is trimmed when the motion fitted inside it departs this many noise levels at its edge.
TRIM_SIGMAS = 10.0


@dataclasses.dataclass(frozen=True)
class Onset:
    """A fitted onset of motion along a track of angles (boundary indices, counted from the rest side)."""

    boundary: int  # the last boundary at rest (motion from here on)
    safe: int  # the boundary a static may reach: ``boundary`` less the margin
    exponent: float
    noise: float  # rms of the rest's residual from its polynomial, in the track's unit
    scale: float = 0.0  # c of the departure ``c (t - t0)^p``, track unit per s^p
    rate_hz: float = 1.0

    def departure(self, boundary: int) -> float:
        """The fitted departure from rest at a boundary on the motion's side (track unit)."""
        return self.scale * (abs(boundary - self.boundary) / self.rate_hz) ** self.exponent


@dataclasses.dataclass(frozen=True)
class AngleTrack:
    """The summed gyro pulses at the sample boundaries (row ``k`` after ``k`` samples), forwards or backwards
    in time, computed only over the windows asked for: a 10 h file's whole track would take gigabytes.
    A window is known up to a constant, which every fit here takes out."""

    gyro: np.ndarray
    backwards: bool = False

    def __len__(self) -> int:
        return len(self.gyro) + 1

    def window(self, lo: int, hi: int) -> np.ndarray:
        """Boundaries ``lo..hi`` (inclusive, in the track's direction), ``(hi - lo + 1, 3)``."""
        if self.backwards:
            n = len(self.gyro)
            return AngleTrack(self.gyro).window(n - hi, n - lo)[::-1]
        return np.vstack([np.zeros((1, 3)), np.cumsum(self.gyro[lo:hi], axis=0)])

    def reversed(self) -> "AngleTrack":
        """The same track backwards in time: boundary ``k`` of it is boundary ``len - 1 - k`` of this one."""
        return AngleTrack(self.gyro, not self.backwards)


def angle_track(gyro: np.ndarray) -> AngleTrack:
    """The summed gyro pulses at every sample boundary (:class:`AngleTrack`)."""
    return AngleTrack(np.asarray(gyro))


def _fit(y: np.ndarray, first: int, last: int, rate_hz: float) -> tuple[int, float, float, float]:
    """Best ``(k0, p, sse, c)`` of ``y ~ a + b k + c (k - k0)_+^p`` over the window's rows, k0 in [first, last]."""
    n = len(y)
    k = np.arange(n, dtype=float)
    basis = np.column_stack([(k / n) ** d for d in range(BASE_DEGREE + 1)])
    q, _ = np.linalg.qr(basis)
    y_perp = y - q @ (q.T @ y)  # (n, 3): the residual of the line alone
    best = (first, EXPONENTS[0], np.inf, 0.0)
    candidates = np.arange(first, last + 1)
    for p in EXPONENTS:
        x = np.clip(k[None, :] - candidates[:, None], 0.0, None) ** p / (rate_hz ** p)  # (K, n), seconds^p
        x_perp = x - (x @ q) @ q.T
        norm2 = np.einsum("kn,kn->k", x_perp, x_perp)
        proj = x_perp @ y_perp  # (K, 3)
        with np.errstate(invalid="ignore", divide="ignore"):
            gain = np.where(norm2 > 0, np.sum(proj**2, axis=1) / norm2, 0.0)
        sse = float(np.sum(y_perp**2)) - gain
        i = int(np.argmin(sse))
        if sse[i] < best[2]:
            c = float(np.linalg.norm(proj[i]) / norm2[i]) if norm2[i] > 0 else 0.0
            best = (int(candidates[i]), p, float(sse[i]), c)
    return best


def onset(track: AngleTrack, rest_first: int, moving: int, rate_hz: float) -> Onset:
    """The onset of motion in ``track`` (angles at sample boundaries, rest first).

    Parameters
    ----------
    track : AngleTrack
        Summed gyro pulses at sample boundaries; at rest from ``rest_first`` until the onset.
    rest_first : int
        The first boundary known to be at rest.
    moving : int
        A boundary where the unit surely moves (the rate magnitude above the resting noise).
    rate_hz : float

    Returns
    -------
    Onset
        The last boundary at rest and the one a static may safely reach.
    """
    rest = int(round(REST_WINDOW_S * rate_hz))
    hi = min(len(track) - 1, moving + int(round(PAST_MOTION_S * rate_hz)))
    lo = max(rest_first, moving - rest)
    minimum = max(3, int(round(ONSET_REST_S * rate_hz)))  # boundaries of rest the line needs at least
    while True:
        first = min(lo + minimum, moving)
        k0, p, _, c = _fit(track.window(lo, hi), first - lo, min(moving + 3, hi) - lo, rate_hz)
        k0 += lo
        if k0 - lo >= rest // 2 or lo == rest_first:  # the onset well inside the window, or nothing more at rest
            break
        lo = max(rest_first, lo - rest)
    y = track.window(lo, k0)
    noise = 0.0
    if len(y) > BASE_DEGREE + 1:
        k = np.arange(len(y), dtype=float) / len(y)
        base = np.polynomial.polynomial.polyfit(k, y, BASE_DEGREE)
        noise = float(np.sqrt(np.mean(np.sum((y - np.polynomial.polynomial.polyval(k, base).T) ** 2, axis=1))))
    margin = (MARGIN_SIGMAS * noise / c) ** (1.0 / p) if c > 0 else MAX_MARGIN_S
    margin_samples = int(round(min(margin, MAX_MARGIN_S) * rate_hz))  # a margin below half a sample: none
    return Onset(k0, max(rest_first, k0 - margin_samples), p, noise, c, rate_hz)


def motion_start(track: AngleTrack, rest_first: int, moving: int, rate_hz: float) -> Onset:
    """:func:`onset` after a static stretch that starts at boundary ``rest_first`` (indices of ``track``)."""
    return onset(track, rest_first, moving, rate_hz)


def motion_end(track: AngleTrack, rest_last: int, moving: int, rate_hz: float) -> Onset:
    """Where motion ends before a static stretch that ends at boundary ``rest_last``: :func:`onset` backwards
    in time; the boundaries returned are indices of ``track``."""
    last = len(track) - 1
    found = onset(track.reversed(), last - rest_last, last - moving, rate_hz)
    return dataclasses.replace(found, boundary=last - found.boundary, safe=last - found.safe)


def trim_rest(track: AngleTrack, moving: np.ndarray, first: int, stop: int, rate_hz: float) -> tuple[int, int]:
    """A stated rest ``[first, stop)`` (samples) with the motion at its edges cut off: ``(first, stop)``.

    Where the rate magnitude shows motion within a second beyond an edge (``moving``, per sample), the
    onset is fitted (:func:`motion_start`, :func:`motion_end`); the edge moves to the onset's safe side
    when the fitted motion inside the rest is at least two samples long and stands :data:`TRIM_SIGMAS`
    noise levels clear at the stated edge (a stated edge within the onset's noise is left as it is).
    """
    reach = max(1, int(round(rate_hz)))
    settle = min(reach, (stop - first) // 4)
    after = np.flatnonzero(moving[stop:stop + reach])
    new_stop = stop
    if after.size:
        coarse = stop + int(after[0])
        found = motion_start(track, first + settle, coarse, rate_hz)
        if _inside(found, stop - found.boundary, coarse - found.boundary, reach):
            new_stop = found.safe
    before = np.flatnonzero(moving[max(0, first - reach):first])
    new_first = first
    if before.size:
        coarse = max(0, first - reach) + int(before[-1])
        found = motion_end(track, stop - settle, coarse, rate_hz)
        if _inside(found, found.boundary - first, found.boundary - coarse, reach):
            new_first = found.safe
    return new_first, max(new_first, new_stop)


def _inside(found: Onset, depth: int, lead: int, reach: int) -> bool:
    """Whether a fitted onset shows motion ``depth`` samples deep inside a stated rest: two samples or more,
    clear of the noise at the stated edge, and no further than ``reach`` from where the rate magnitude sees
    the motion (``lead`` samples; a fit further off took a sway's wander for motion)."""
    edge = found.boundary + depth  # on the motion's side, in the fit's direction
    return depth >= 2 and lead <= reach and found.departure(edge) > TRIM_SIGMAS * found.noise


@dataclasses.dataclass
class MotionSpan:
    """A stretch of samples in which the unit moves."""

    first: int  # first moving sample
    stop: int  # one past the last moving sample


@dataclasses.dataclass
class Activity:
    """The rate magnitude and the thresholds that tell rest from motion."""

    magnitude: np.ndarray  # smoothed gyro pulse-rate magnitude per sample
    rest: float
    peak: float
    core: float
    edge: float
    contrast: float = np.inf  # (peak - rest) over the resting level's own scatter: small when nothing turns

    @property
    def moves(self) -> bool:
        """Whether anything turns at all (the peak stands out from the rest's scatter)."""
        return self.contrast > MIN_CONTRAST


def activity(gyro: np.ndarray, rate_hz: float) -> Activity:
    """Smoothed gyro rate magnitude (pulses per sample) and its thresholds."""
    width = max(1, int(round(SMOOTH_S * rate_hz)))
    kernel = np.ones(width) / width
    smooth = np.column_stack([np.convolve(gyro[:, k], kernel, mode="same") for k in range(3)])
    magnitude = np.linalg.norm(smooth, axis=1)
    rest = float(np.percentile(magnitude, 20))
    peak = float(np.percentile(magnitude, 99.99))
    core = rest + 0.2 * (peak - rest)
    quiet = magnitude[magnitude < rest + 0.05 * (peak - rest)]
    spread = float(np.percentile(np.abs(quiet - np.median(quiet)), 95)) if len(quiet) else 0.0
    edge = rest + max(6.0 * spread, 0.005 * (peak - rest))
    scatter = max(rest - float(np.percentile(magnitude, 1)), 1e-9 * max(rest, 1e-300))
    return Activity(magnitude, rest, peak, core, edge, (peak - rest) / scatter)


def find_motions(act: Activity, rate_hz: float, min_static_s: float = 20.0) -> list[MotionSpan]:
    """Moving stretches: cores above the core threshold, widened to the edge threshold, merged across rests
    shorter than ``min_static_s``."""
    runs = _runs(act.magnitude > act.edge)
    moving = [MotionSpan(a, b) for a, b in runs if np.any(act.magnitude[a:b] > act.core)]
    merged: list[MotionSpan] = []
    for m in moving:
        if merged and (m.first - merged[-1].stop) < min_static_s * rate_hz:
            merged[-1].stop = m.stop
        else:
            merged.append(m)
    return merged


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return list(zip(edges[0::2], edges[1::2]))


def jumps(gyro: np.ndarray, accel: np.ndarray, first: int, stop: int, block: int, longest: int) -> list[int]:
    """Samples in ``[first, stop)`` where the attitude jumps with no motion (a new rest starts there), by
    binary segmentation of the mean specific force (its direction) and the mean gyro rate.

    Each change must stand far above the scatter of the means over ``block`` samples (1 s; a sway's
    included) and leave ``block`` samples on either side; the pieces are searched again while they are at
    least ``longest`` samples long (two static segments), so the search ends on any data.
    """
    if stop - first < max(2 * block, longest) or block < 1:
        return []
    for pulses, test in ((accel, _force_jump), (gyro, _rate_jump)):
        part = pulses[first:stop]
        n = len(part)
        total = part.sum(axis=0)
        k = np.arange(block, n - block + 1)
        left = np.cumsum(part, axis=0)[k - 1]
        mean_left, mean_right = left / k[:, None], (total - left) / (n - k)[:, None]
        score = np.sum((mean_left - mean_right) ** 2, axis=1) * k * (n - k) / n
        i = int(np.argmax(score))
        if test(mean_left[i], mean_right[i]) and _stands_out(part, block, mean_left[i], mean_right[i]):
            split = first + int(k[i])
            return (jumps(gyro, accel, first, split, block, longest) + [split]
                    + jumps(gyro, accel, split, stop, block, longest))
    return []


def _force_jump(before, after) -> bool:
    """The mean specific force turns by more than :data:`JUMP_FORCE_DEG`."""
    cos = before @ after / (np.linalg.norm(before) * np.linalg.norm(after) + 1e-300)
    return bool(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))) > JUMP_FORCE_DEG)


def _rate_jump(before, after) -> bool:
    """The mean gyro rate changes by more than :data:`JUMP_RATE_SHARE` of its magnitude."""
    change = float(np.linalg.norm(after - before))
    return bool(change > JUMP_RATE_SHARE * float(np.linalg.norm(before + after)) / 2.0)


def _stands_out(part, block, before, after) -> bool:
    """The change of the mean is :data:`JUMP_SIGMAS` times the typical step between consecutive means over
    ``block`` samples (white noise, a sway's wander or pure noise alike)."""
    means = part[: len(part) // block * block].reshape(-1, block, 3).mean(axis=1)
    if len(means) < 4:
        return False
    scatter = float(np.median(np.linalg.norm(np.diff(means, axis=0), axis=1)))
    return bool(np.linalg.norm(after - before) > JUMP_SIGMAS * scatter)


def static_stretches(gyro: np.ndarray, accel: np.ndarray, rate_hz: float, min_static_s: float):
    """The rests of a recording: ``(stretches, jumps_at, motions)``.

    ``stretches`` are ``(first, stop)`` sample ranges of at least ``min_static_s``, their edges at the
    fitted onsets (:func:`motion_start`, :func:`motion_end`) and split where the attitude jumps
    (``jumps_at``: the samples where a rest begins after a jump); ``motions`` the moving stretches
    (none when nothing turns at all).
    """
    act = activity(gyro, rate_hz)
    motions = find_motions(act, rate_hz, min_static_s) if act.moves else []
    track = angle_track(gyro)
    n = len(gyro)
    shortest = int(round(min_static_s * rate_hz))
    bounds = [0] + [x for m in motions for x in (m.first, m.stop)] + [n]
    stretches: list[tuple[int, int]] = []
    jumps_at: list[int] = []
    for a, b in zip(bounds[0::2], bounds[1::2]):
        if b - a < shortest:
            continue
        settle = min(int(round(rate_hz)), (b - a) // 4)  # the edges' fits start this far inside the rest
        start = a if a == 0 else motion_end(track, b - settle, a - 1, rate_hz).safe
        stop = b if b == n else motion_start(track, a + settle, b, rate_hz).safe
        cuts = jumps(gyro, accel, start, stop, max(1, int(round(rate_hz))), 2 * shortest)
        jumps_at += cuts
        edges = [start] + cuts + [stop]
        stretches += [(p, q) for p, q in zip(edges[:-1], edges[1:]) if q - p >= shortest]
    return stretches, jumps_at, motions
