"""Segmentation: the schedule of a recording found from its own signals (``casadi-sins segment``).

A turntable log rarely gives exact segment times.  The motion shows in the gyros: at rest they see
the Earth rate (15 deg/h), turning they see degrees per second, a ratio of thousands.  So:

1. the gyro rate magnitude (pulses, smoothed over 50 ms) separates *cores* of motion (above a fifth
   of the way from the resting level to the peak) from rest; each core is widened to where the rate
   comes back to the resting level (its spread, a sway included, times six, or 0.5 % of the peak);
   quiet stretches shorter than ``min_static_s`` belong to the motion around them, and a static
   segment keeps 0.1 s clear of the motion beside it;
2. the pulses' sizes are unknown, but at rest the gyros must see the Earth rate and the
   accelerometers 1 g: least squares over the static stretches gives rough sizes (about 1 %, a tenth
   on a swaying base); the gyros' are refined by the turns, which are multiples of 90 deg;
3. each motion is a rotation when its turned angle (the summed gyro pulses, less the resting rate) is
   close to a multiple of 90 deg about one body axis; otherwise it is handling between groups;
4. each static stretch gets its orientation letters from gravity (up) and the Earth rate (north);
   the letters after a rotation must follow from those before, or a new group starts;
5. groups need a rotation; segments are written in the interchange format, times as the sample
   intervals' bounds.

:func:`refine` checks a given description against the same signals: motion at the edge of a static
segment is trimmed off (a warning), motion inside one is an error naming it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core import orientation as orient
from ..core.earth import EARTH_RATE, Site
from ..core.errors import InputError
from ..core.rotations import triad
from .recording import Recording, Segment, validate_schedule

#: Seconds of smoothing of the rate magnitude, and the shortest rest that counts as a static segment.
SMOOTH_S = 0.05
MIN_STATIC_S = 20.0
#: Seconds of guard between a static segment and the motion found beside it.
GUARD_S = 0.1
#: A turn is a rotation of the schedule when its angle is within this of a multiple of 90 deg, and its
#: axis within this share of a body axis (the rest: handling).
ANGLE_TOLERANCE_DEG = 8.0
AXIS_TOLERANCE = 0.1


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
    return Activity(magnitude, rest, peak, core, edge)


def find_motions(act: Activity, rate_hz: float, min_static_s: float = MIN_STATIC_S) -> list[MotionSpan]:
    """Moving stretches: cores above the core threshold, widened to the edge threshold, merged across rests
    shorter than ``min_static_s``."""
    above = act.magnitude > act.edge
    runs = _runs(above)
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


def _rough_sizes(means: np.ndarray, magnitude: float, dt: float) -> np.ndarray | None:
    """Per-axis pulse sizes with ``|size * mean| = magnitude dt`` over the static stretches (least squares)."""
    design = means**2
    if len(means) < 3 or np.linalg.matrix_rank(design) < 3:
        return None
    u, *_ = np.linalg.lstsq(design, np.full(len(means), (magnitude * dt) ** 2), rcond=None)
    return np.sqrt(u) if np.all(u > 0) else None


def detect(time: np.ndarray, gyro: np.ndarray, accel: np.ndarray, rate_hz: float, site: Site,
           min_static_s: float = MIN_STATIC_S) -> tuple[list[Segment], list[str]]:
    """The segments of a recording found from its signals, and notes on what was taken for handling."""
    dt = 1.0 / rate_hz
    act = activity(gyro, rate_hz)
    motions = find_motions(act, rate_hz, min_static_s)
    guard = int(round(GUARD_S * rate_hz))  # statics keep clear of the motion's slow start and end
    bounds = [0] + [x for m in motions for x in (max(m.first - guard, 0), min(m.stop + guard, len(time)))] + \
        [len(time)]
    statics = [(a, b) for a, b in zip(bounds[0::2], bounds[1::2]) if (b - a) * dt >= min_static_s]
    if len(statics) < 2:
        raise InputError(None, f"found {len(statics)} static stretch(es) of at least {min_static_s:g} s: no schedule "
                             "of static positions and rotations")
    gyro_means = np.array([gyro[a:b].mean(axis=0) for a, b in statics])
    accel_means = np.array([accel[a:b].mean(axis=0) for a, b in statics])
    accel_size = _rough_sizes(accel_means, site.g, dt)
    gyro_size = _rough_sizes(gyro_means, EARTH_RATE, dt)
    if accel_size is None:
        raise InputError(None, "the static stretches do not show gravity on all three accelerometer axes: cannot "
                             "size the pulses")
    if gyro_size is None:  # equal gyro pulse sizes, from the Earth-rate magnitude
        gyro_size = np.full(3, EARTH_RATE * dt / float(np.mean(np.linalg.norm(gyro_means, axis=1))))
    gyro_size = _sizes_from_turns(gyro, statics, gyro_means, gyro_size)
    letters = [_orientation(f * accel_size, w * gyro_size) for f, w in zip(accel_means, gyro_means)]
    notes = []
    segments: list[Segment] = []
    group = 0
    previous = None  # (static index) of the last static of the current group
    for k, (a, b) in enumerate(statics):
        start, end = float(time[a] - dt), float(time[b - 1])
        turn = None
        if previous is not None:
            pa, pb = statics[previous]
            resting = (gyro_means[previous] + gyro_means[k]) / 2.0
            turn = _turn(gyro[pb:a] - resting, gyro_size)
            if turn is not None and letters[previous] and letters[k]:
                expected = orient.rotate_body(orient.orientation_to_dcm(letters[previous]), turn[0],
                                              math.radians(turn[1]))
                if np.abs(expected - orient.orientation_to_dcm(letters[k])).max() > 1e-6:
                    notes.append(f"{time[pb - 1]:.2f}-{time[a] - dt:.2f} s: {turn[0]} {turn[1]:g} deg does not lead "
                                 f"from {letters[previous]} to {letters[k]}: taken for handling")
                    turn = None
            elif turn is None:
                notes.append(f"{time[pb - 1]:.2f}-{time[a] - dt:.2f} s: not a turn of a multiple of 90 deg about one "
                             "body axis: taken for handling between groups")
        if letters[k] is None:
            notes.append(f"{start:.2f}-{end:.2f} s: the unit is not near an orientation of the letters N S E W U D "
                         "there: left out")
            previous = None
            continue
        if turn is None:
            group += 1
        else:
            segments.append(Segment(len(segments) + 1, group, "rotation", float(time[statics[previous][1] - 1]),
                                    start, axis=turn[0], angle_deg=turn[1]))
        segments.append(Segment(len(segments) + 1, group, "static", start, end, orientation=letters[k]))
        previous = k
    # groups need a rotation: a lone static position calibrates nothing
    kept = [g for g in {s.group for s in segments} if sum(1 for s in segments if s.group == g) > 1]
    dropped = sorted({s.group for s in segments} - set(kept))
    if dropped:
        notes.append(f"{len(dropped)} lone static position(s) without a rotation left out")
    renumber = {g: i + 1 for i, g in enumerate(sorted(kept))}
    out = [dataclasses.replace(s, group=renumber[s.group]) for s in segments if s.group in renumber]
    return [dataclasses.replace(s, number=i + 1) for i, s in enumerate(out)], notes


def _sizes_from_turns(gyro: np.ndarray, statics, gyro_means: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Refine the gyro pulse sizes with the turns themselves: a sway or a bias spoils the Earth rate by
    a tenth, the turns' multiples of 90 deg do not.  Turns near a multiple of 90 deg (within 30 %) give
    each axis the median of nominal angle over pulses; an axis that never turns keeps its size."""
    ratios: list[list[float]] = [[], [], []]
    for k in range(1, len(statics)):
        pulses = (gyro[statics[k - 1][1]:statics[k][0]] - (gyro_means[k - 1] + gyro_means[k]) / 2.0).sum(axis=0)
        rotation = np.degrees(pulses * size)
        axis = int(np.argmax(np.abs(rotation)))
        angle = abs(rotation[axis])
        nominal = 90.0 * round(angle / 90.0)
        if nominal and abs(angle - nominal) < 0.3 * 90.0 and \
                np.linalg.norm(np.delete(rotation, axis)) < 3 * AXIS_TOLERANCE * angle:
            ratios[axis].append(np.radians(nominal) / abs(pulses[axis]))
    return np.array([np.median(r) if r else size[i] for i, r in enumerate(ratios)])


def _turn(pulses: np.ndarray, size: np.ndarray) -> tuple[str, float] | None:
    """``(axis, angle_deg)`` of a motion when it is a turn of a multiple of 90 deg about one body axis."""
    rotation = np.degrees(pulses.sum(axis=0) * size)
    norm = float(np.linalg.norm(rotation))
    if norm < 45.0:
        return None
    axis = int(np.argmax(np.abs(rotation)))
    if np.linalg.norm(np.delete(rotation, axis)) > AXIS_TOLERANCE * norm:
        return None
    angle = abs(rotation[axis])
    nominal = 90.0 * round(angle / 90.0)
    if nominal == 0 or abs(angle - nominal) > ANGLE_TOLERANCE_DEG:
        return None
    sign = "+" if rotation[axis] > 0 else "-"
    return f"{sign}{'XYZ'[axis]}", float(nominal)


def _orientation(force: np.ndarray, rate: np.ndarray) -> str | None:
    """Letters of a static attitude: the coarse alignment (up from gravity, north from the Earth rate's
    horizontal part), to the nearest letters."""
    with np.errstate(invalid="ignore", divide="ignore"):
        attitude = triad(force, rate)  # the coarse alignment (eq. 14)
    if not np.all(np.isfinite(attitude)):  # no horizontal Earth rate: no heading
        return None
    try:
        return orient.dcm_to_orientation(attitude, tol_deg=30.0)
    except orient.OrientationError:
        return None


def segment_recording(time, gyro, accel, rate_hz: float, site: Site, name: str,
                      min_static_s: float = MIN_STATIC_S) -> tuple[Recording, list[str]]:
    """A validated recording whose segments were found in its data (see the module docstring)."""
    segments, notes = detect(time, gyro, accel, rate_hz, site, min_static_s)
    rec = Recording(name=name, site=site, rate_hz=rate_hz, segments=segments, time=time, gyro=gyro, accel=accel)
    validate_schedule(rec)
    return rec, notes


def refine(rec: Recording, min_static_s: float = 5.0) -> Recording:
    """Check a description's static segments against the data: trim motion at their edges (the rotations
    beside them grow to meet them; a warning in ``rec.warnings``), reject motion inside one (naming it)."""
    act = activity(rec.gyro, rec.rate_hz)
    moving = act.magnitude > act.edge
    changed = []
    segments = list(rec.segments)
    for i, seg in enumerate(segments):
        if not seg.is_static:
            continue
        sl = rec.segment_samples(seg)
        flags = moving[sl]
        if not flags.any():
            continue
        quiet = np.flatnonzero(~flags)
        if len(quiet) == 0 or flags[quiet[0]:quiet[-1] + 1].any() or (quiet[-1] + 1 - quiet[0]) * rec.dt < min_static_s:
            times = rec.time[sl][flags]
            raise InputError(rec.label, f"{seg.describe()} holds motion inside it ({times[0]:.2f}-{times[-1]:.2f} "
                                 "s): check the segment times, or let `casadi-sins segment` find them")
        start = max(float(rec.time[sl.start + quiet[0]] - rec.dt), seg.start)
        end = min(float(rec.time[sl.start + quiet[-1]]), seg.end)
        changed.append(f"{seg.describe()} trimmed to {start:.2f}-{end:.2f} s: the unit still moved at its edge")
        segments[i] = dataclasses.replace(seg, start=start, end=end)
    if not changed:
        return rec
    for i, seg in enumerate(segments):  # the rotations meet the trimmed statics of their group
        if not seg.is_static:
            before, after = segments[i - 1], segments[i + 1]
            segments[i] = dataclasses.replace(seg, start=before.end, end=after.start)
    out = dataclasses.replace(rec, segments=segments, warnings=list(rec.warnings) + changed)
    validate_schedule(out)
    return out
