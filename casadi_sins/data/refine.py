"""The check of a given description against its data (:func:`refine`), before a calibration.

Motion at the edge of a static segment is trimmed off at its fitted onset (a warning says so, never left
to look like a swaying base); a jerk of the hand inside one (less than :data:`JERK_DEG`) leaves its
longest quiet part; a turn inside one is an error naming it; and a rest shorter than what it must
determine (:func:`data.rests.minimum_rest`, or ``--min-rest-s``) is an error that names the option.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.errors import InputError
from .edges import activity, angle_track, trim_rest
from .recording import Recording, Segment, validate_schedule
from .rests import minimum_rest
from .stillness import rest_baseline


#: Motion inside a stated static segment that turns less than this is a jerk of the hand (a wobble).
JERK_DEG = 45.0


def _quiet_part(rec: Recording, seg: Segment, moving: np.ndarray, shortest_s: float) -> tuple[int, int, str | None]:
    """``(first, stop, warning)``: the samples of a static segment from its first to its last quiet one.

    With motion between them the segment keeps its longest quiet run (a warning says so) when the rest of it
    is a jerk of the hand (turning less than :data:`JERK_DEG`) or a turn with pauses shorter than a rest
    (``shortest_s``) that the turn beside it takes over (the calibration navigates the measured motion);
    a second position inside it (a quiet run of a rest's length beyond a turn) is an error naming it, unless the
    segment is a rest at any orientation: its free moves take whatever is no rest (no letters to contradict).
    """
    sl = rec.segment_samples(seg)
    flags = moving[sl]
    quiet = np.flatnonzero(~flags)
    if len(quiet) and not flags[quiet[0]:quiet[-1] + 1].any():
        return sl.start + int(quiet[0]), sl.start + int(quiet[-1]) + 1, None
    times = rec.time[sl][flags]
    refusal = InputError(rec.label, f"{seg.describe()} holds motion inside it ({times[0]:.2f}-{times[-1]:.2f} s): "
                         "check the segment times, or let `casadi-sins segment` find them")
    if not len(quiet):
        raise refusal
    edges = np.flatnonzero(np.diff(np.concatenate([[1], flags.astype(np.int8), [1]])))
    runs = sorted(zip(edges[0::2], edges[1::2]), key=lambda r: r[1] - r[0])
    first, stop = runs[-1]
    inside = slice(sl.start + int(quiet[0]), sl.start + int(quiet[-1]) + 1)
    rest = rec.gyro[inside][~moving[inside]].mean(axis=0)
    turned = np.degrees(np.linalg.norm(_rad_per_pulse(rec) * (rec.gyro[inside] - rest).sum(axis=0)))
    other_rest = any((b - a) * rec.dt >= shortest_s for a, b in runs[:-1])
    if other_rest and not turned < JERK_DEG and not seg.is_free:
        raise refusal
    what = (f"a jerk of {turned:.2g} deg" if turned < JERK_DEG else
            "motion" if seg.is_free else "part of the turn beside it")
    return sl.start + int(first), sl.start + int(stop), (
        f"{seg.describe()}: {what} inside it ({times[0]:.2f}-{times[-1]:.2f} s); its longest quiet part is kept "
        "and the turns beside it take the rest")


def _rad_per_pulse(rec: Recording) -> np.ndarray:
    """Rough gyro pulse sizes (rad) from the stated turns: the median of nominal angle over the summed pulses
    (less the rate of the static before) about each turn's axis."""
    sizes = []
    for group in rec.group_ids:
        segs = rec.group_segments(group)
        for before, rotation in zip(segs[0::2], segs[1::2]):
            if rotation.is_free:
                continue
            rest = rec.gyro[rec.segment_samples(before)].mean(axis=0)
            part = rec.segment_samples(rotation)
            total = float(np.linalg.norm((rec.gyro[part] - rest).sum(axis=0)))
            if total > 0:
                sizes.append(np.radians(abs(rotation.angle_deg)) / total)
    return np.median(sizes) if sizes else np.inf


def _below(seconds: float) -> str:
    """A round number of seconds just under ``seconds`` (the option a refusal suggests)."""
    return f"{math.floor(seconds * 10.0) / 10.0:g}" if seconds >= 0.2 else f"{seconds * 0.9:.2g}"


def refine(rec: Recording, min_rest_s: float | None = None) -> Recording:
    """Check a description's static segments against the data: trim motion at their edges (the rotations
    beside them grow to meet them; a warning in ``rec.warnings`` saying so), reject motion inside one
    (naming it), and a rest shorter than ``min_rest_s`` (default: what a rest must determine given the
    measured noise and rate, :func:`data.rests.minimum_rest`).

    The rate magnitude (after each stated rest's own level, offset and bias included, is taken off) finds motion
    well inside a segment; the edges are then placed at the fitted onset
    of the motion beside them (:func:`data.edges.trim_rest`), so that slow handling or a turn that a
    stated time runs into is cut off rather than left to look like a swaying base.  A description that
    needs nothing is returned as it is (the same object).
    """
    rule = minimum_rest(rec, min_rest_s)
    # the size of the motion after each stated rest's own level is taken off: any offset (raw counts) works
    baseline = rest_baseline(rec.gyro, [(sl.start, sl.stop) for sl in map(rec.segment_samples, rec.static_segments)])
    act = activity(rec.gyro - baseline, rec.rate_hz)
    moving = act.magnitude > act.edge
    track = angle_track(rec.gyro)
    changed = []
    segments = list(rec.segments)
    for i, seg in enumerate(segments):
        if not seg.is_static:
            continue
        sl = rec.segment_samples(seg)
        quiet_first, quiet_stop, jerk = _quiet_part(rec, seg, moving, rule.seconds)
        if jerk:
            changed.append(jerk)
        first, stop = trim_rest(track, moving, quiet_first, quiet_stop, rec.rate_hz)
        if (stop - first) * rec.dt < rule.seconds:
            raise InputError(rec.label, f"{seg.describe()} is at rest for only {(stop - first) * rec.dt:.2f} s, "
                             f"under the shortest rest ({rule.reason}): check the segment times, or state "
                             f"--min-rest-s {_below((stop - first) * rec.dt)}")
        if (first, stop) == (sl.start, sl.stop):
            continue
        start = max(round(float(rec.time[first] - rec.dt), 9), seg.start)
        end = min(round(float(rec.time[stop - 1]), 9), seg.end)
        cut = [f"first {(first - sl.start) * rec.dt:.2f} s" if first > sl.start else "",
               f"last {(sl.stop - stop) * rec.dt:.2f} s" if stop < sl.stop else ""]
        changed.append(f"{seg.describe()} trimmed to {start:.2f}-{end:.2f} s: the unit was still moving in its "
                       f"{' and '.join(c for c in cut if c)} (motion at a static segment's edge, cut off)")
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
