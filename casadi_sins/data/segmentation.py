"""Segmentation: the schedule of a recording found from its own signals (``casadi-sins segment``).

A turntable log rarely gives exact segment times.  The motion shows in the gyros: at rest they see
the Earth rate (15 deg/h), turning they see degrees per second, a ratio of thousands.  So:

1. the gyro rate magnitude (pulses, smoothed over 50 ms) separates *cores* of motion (above a fifth
   of the way from the resting level to the peak) from rest; each core is widened to where the rate
   comes back to the resting level (its spread, a sway included, times six, or 0.5 % of the peak);
   quiet stretches shorter than ``min_static_s`` belong to the motion around them.  The rests' edges
   are then placed at the fitted onset of the motion beside them, from the gyro-integrated angle's
   departure from rest (:mod:`data.edges`: to a sample for the paper's turns, within 0.1 s for slow
   handling, on the rest's safe side), and a rest in which the attitude jumps with no motion at all
   (groups of a simulation joined without handling) is split there;
2. the pulses' sizes are unknown, but at rest the gyros must see the Earth rate and the
   accelerometers 1 g: least squares over the static stretches gives rough sizes (about 1 %, a tenth
   on a swaying base); the gyros' are refined by the turns, which are multiples of 90 deg;
3. each motion is a rotation when its turned angle (the summed gyro pulses, less the resting rate) is
   close to a multiple of 90 deg about one body axis; otherwise it is handling between groups;
4. each static stretch gets its orientation letters from gravity (up) and the Earth rate (north);
   the letters after a rotation must follow from those before, or a new group starts;
5. groups need a rotation; segments are written in the interchange format, times as the sample
   intervals' bounds.

When no schedule is found :func:`detect` says why, in one :class:`~core.errors.InputError`: nothing
turns, the rests are too short, the gyros at rest read a bias far above the Earth rate (the same in
every orientation: a MEMS unit, outside this design), or no motion is a turn of a multiple of 90 deg.

:func:`refine` checks a given description against the same signals: motion at the edge of a static
segment is trimmed off at its fitted onset (a warning that says so, never left to look like a sway),
motion inside one is an error naming it.  :func:`calibrate.calibrate` refines before it calibrates.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core import orientation as orient
from ..core.earth import EARTH_RATE, Site
from ..core.errors import InputError
from ..core.rotations import triad
from .edges import Activity, MotionSpan, activity, angle_track, find_motions, static_stretches, trim_rest  # noqa: F401
from .recording import Recording, Segment, validate_schedule
from .handling import detect_handled
from .refine import refine  # noqa: F401  (the check of a given description, beside the search for one)

#: The shortest rest that counts as a static segment (s).
MIN_STATIC_S = 20.0
#: A turn is a rotation of the schedule when its angle is within this of a multiple of 90 deg, and its
#: axis within this share of a body axis (the rest: handling).
ANGLE_TOLERANCE_DEG = 8.0
AXIS_TOLERANCE = 0.1


def _rough_sizes(means: np.ndarray, magnitude: float, dt: float) -> np.ndarray | None:
    """Per-axis pulse sizes with ``|size * mean| = magnitude dt`` over the static stretches (least squares)."""
    design = means**2
    if len(means) < 3 or np.linalg.matrix_rank(design) < 3:
        return None
    u, *_ = np.linalg.lstsq(design, np.full(len(means), (magnitude * dt) ** 2), rcond=None)
    return np.sqrt(u) if np.all(u > 0) else None


def detect(time: np.ndarray, gyro: np.ndarray, accel: np.ndarray, rate_hz: float, site: Site,
           min_static_s: float = MIN_STATIC_S) -> tuple[list[Segment], list[str]]:
    """The segments of a recording found from its signals, and notes on what was taken for handling.

    Raises
    ------
    InputError
        When no schedule is found, saying why: no motion, rests too short, a gyro bias far above the
        Earth rate, turns that are not multiples of 90 deg, attitudes off the letters.
    """
    if not (math.isfinite(min_static_s) and min_static_s > 0.0):
        raise InputError(None, f"the shortest static segment must be a positive number of seconds, found "
                               f"{min_static_s!r}")
    dt = 1.0 / rate_hz
    statics, jumps_at, motions = static_stretches(gyro, accel, rate_hz, min_static_s)
    if len(statics) < 2:
        raise InputError(None, _few_rests(gyro, accel, rate_hz, len(statics), motions, min_static_s))
    gyro_means = np.array([gyro[a:b].mean(axis=0) for a, b in statics])
    accel_means = np.array([accel[a:b].mean(axis=0) for a, b in statics])
    ratio = bias_ratio(gyro_means, accel_means)
    if ratio > BIAS_RATIO_LIMIT:
        raise InputError(None, _bias_reason(ratio))
    accel_size = _rough_sizes(accel_means, site.g, dt)
    gyro_size = _rough_sizes(gyro_means, EARTH_RATE, dt)
    if accel_size is None:
        raise InputError(None, "the static stretches do not show gravity on all three accelerometer axes: cannot "
                             "size the pulses")
    if gyro_size is None:  # equal gyro pulse sizes, from the Earth-rate magnitude
        gyro_size = np.full(3, EARTH_RATE * dt / float(np.mean(np.linalg.norm(gyro_means, axis=1))))
    gyro_size = _sizes_from_turns(gyro, statics, gyro_means, gyro_size)
    letters = [_orientation(f * accel_size, w * gyro_size) for f, w in zip(accel_means, gyro_means)]
    segments, notes = _chain(time, gyro, statics, set(jumps_at), gyro_means, gyro_size, letters)
    out = _with_rotations(segments, notes)
    if not out:
        raise InputError(None, _no_turns(gyro, statics, set(jumps_at), gyro_means, gyro_size, accel_means, letters))
    return out, notes


def _with_rotations(segments: list[Segment], notes: list[str]) -> list[Segment]:
    """The groups that hold a rotation, renumbered (a lone static position calibrates nothing; a note says so)."""
    kept = [g for g in {s.group for s in segments} if sum(1 for s in segments if s.group == g) > 1]
    dropped = sorted({s.group for s in segments} - set(kept))
    if dropped:
        notes.append(f"{len(dropped)} lone static position(s) without a rotation left out")
    renumber = {g: i + 1 for i, g in enumerate(sorted(kept))}
    out = [dataclasses.replace(s, group=renumber[s.group]) for s in segments if s.group in renumber]
    return [dataclasses.replace(s, number=i + 1) for i, s in enumerate(out)]


def _chain(time, gyro, statics, jumps_at: set, gyro_means, gyro_size, letters):
    """Static stretches joined by turns into groups: ``(segments, notes)``; a motion that is no turn of a
    multiple of 90 deg leading from one rest's letters to the next's, or an attitude jump, starts a group."""
    dt = time[1] - time[0] if len(time) > 1 else 0.0
    notes = []
    segments: list[Segment] = []
    group = 0
    previous = None  # (static index) of the last static of the current group
    for k, (a, b) in enumerate(statics):
        start, end = round(float(time[a] - dt), 9), round(float(time[b - 1]), 9)
        turn = None
        if previous is not None and a in jumps_at and statics[previous][1] == a:
            notes.append(f"{start:.2f} s: the attitude jumps with no motion (groups joined without handling): a new "
                         "group starts")
        elif previous is not None:
            pb = statics[previous][1]
            pulses = gyro[pb:a] - (gyro_means[previous] + gyro_means[k]) / 2.0
            turn = _turn(pulses, gyro_size)
            if turn is not None and letters[previous] and letters[k]:
                expected = orient.rotate_body(orient.orientation_to_dcm(letters[previous]), turn[0],
                                              math.radians(turn[1]))
                if np.abs(expected - orient.orientation_to_dcm(letters[k])).max() > 1e-6:
                    notes.append(f"{time[pb - 1]:.2f}-{start:.2f} s: {turn[0]} {turn[1]:g} deg does not lead "
                                 f"from {letters[previous]} to {letters[k]}: taken for handling")
                    turn = None
            elif turn is None:
                angle = float(np.linalg.norm(np.degrees(pulses.sum(axis=0) * gyro_size)))
                notes.append(f"{time[pb - 1]:.2f}-{start:.2f} s: not a turn of a multiple of 90 deg about one "
                             f"body axis ({angle:.3g} deg): taken for handling between groups")
        if letters[k] is None:
            notes.append(f"{start:.2f}-{end:.2f} s: the unit is not near an orientation of the letters N S E W U D "
                         "there: left out")
            previous = None
            continue
        if turn is None:
            group += 1
        else:
            turn_start = round(float(time[statics[previous][1] - 1]), 9)
            segments.append(Segment(len(segments) + 1, group, "rotation", turn_start, start, axis=turn[0],
                                    angle_deg=turn[1]))
        segments.append(Segment(len(segments) + 1, group, "static", start, end, orientation=letters[k]))
        previous = k
    return segments, notes


#: A resting gyro rate this many times its change between orientations is a bias far above the Earth rate.
BIAS_RATIO_LIMIT = 10.0


def bias_ratio(gyro_means: np.ndarray, accel_means: np.ndarray) -> float:
    """The resting gyro rate over half its largest change between static stretches whose gravity differs by
    more than 30 deg: about 1 for a navigation-grade unit (the Earth rate turns with the unit), about
    bias / Earth rate when a bias far above the Earth rate reads the same in every orientation; 0 when
    no two stretches differ so.  Pulse sizes do not enter."""
    level = float(np.median(np.linalg.norm(gyro_means, axis=1))) if len(gyro_means) else 0.0
    up = accel_means / np.maximum(np.linalg.norm(accel_means, axis=1, keepdims=True), 1e-300)
    changes = [float(np.linalg.norm(gyro_means[i] - gyro_means[j])) for i in range(len(up))
               for j in range(i + 1, len(up)) if up[i] @ up[j] < np.cos(np.radians(30.0))]
    if not changes or level == 0.0:
        return 0.0
    return level / max(max(changes) / 2.0, 1e-300 * level)


def _bias_reason(ratio: float) -> str:
    return (f"at rest the gyros read about {ratio:.3g} times what turning between the static positions changes in "
            "them: a gyro bias far above the Earth rate (15 deg/h), as of a MEMS unit. This calibration needs the "
            "Earth rate to show in the gyros at rest (a navigation-grade unit): outside its design")


def _few_rests(gyro, accel, rate_hz: float, found: int, motions, min_static_s: float) -> str:
    """Why fewer than two rests were found: nothing turns, or the rests are too short (or a large gyro bias)."""
    if not motions:
        return "no motion in the gyros (only rest, or noise): no schedule of static positions and rotations"
    short, *_ = static_stretches(gyro, accel, rate_hz, 1.0)
    longest = max([b - a for a, b in short], default=0) / rate_hz
    reason = (f"found {found} rest(s) of at least {min_static_s:g} s between the motions, the longest lasts "
              f"{longest:.3g} s: rests too short for static positions (--min-static-s sets the shortest)")
    ratio = bias_ratio(np.array([gyro[a:b].mean(axis=0) for a, b in short]),
                       np.array([accel[a:b].mean(axis=0) for a, b in short])) if len(short) > 1 else 0.0
    return _bias_reason(ratio) + "; and " + reason if ratio > BIAS_RATIO_LIMIT else reason


def _no_turns(gyro, statics, jumps_at: set, gyro_means, gyro_size, accel_means, letters) -> str:
    """Why no group was found among the rests: no motion is a turn of a multiple of 90 deg (by the gyros,
    or by gravity's direction, which needs no pulse size), no rest has letters, or the turns do not lead
    from one rest's letters to the next's."""
    angles, tilts, turns = [], [], 0
    for k in range(1, len(statics)):
        if statics[k][0] in jumps_at and statics[k - 1][1] == statics[k][0]:
            continue
        pulses = gyro[statics[k - 1][1]:statics[k][0]] - (gyro_means[k - 1] + gyro_means[k]) / 2.0
        angles.append(float(np.linalg.norm(np.degrees(pulses.sum(axis=0) * gyro_size))))
        turns += _turn(pulses, gyro_size) is not None
        a, b = accel_means[k - 1], accel_means[k]
        tilts.append(float(np.degrees(np.arccos(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)), -1, 1)))))
    off = [t for t in tilts if abs(t - 90.0 * round(t / 90.0)) > ANGLE_TOLERANCE_DEG]
    if angles and (not turns or off):
        shown_angles = ", ".join(f"{a:.3g}" for a in (off or angles)[:6]) + (", ..." if len(off or angles) > 6 else "")
        what = "gravity turned by" if off else "they turned"
        return (f"the motions between the rests are no turns of a multiple of 90 deg about one body axis ({what} "
                f"{shown_angles} deg): no schedule of static positions and rotations")
    lost = sum(x is None for x in letters)
    if lost:
        return (f"{lost} of the {len(statics)} rests are not near an orientation of the letters N S E W U D (within "
                "30 deg; turns that are no multiples of 90 deg lead off them), and no two others are joined by a "
                "turn: no schedule")
    return "no two rests are joined by a turn of a multiple of 90 deg that leads from one to the other: no schedule"


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
                      min_static_s: float | None = None) -> tuple[Recording, list[str]]:
    """A validated recording whose segments were found in its data (see the module docstring).

    Without ``min_static_s`` a turntable schedule is looked for first (rests of :data:`MIN_STATIC_S`); when
    there is none, a session turned by hand (:mod:`data.handling`: rests at any orientation joined by free moves,
    found from the changes of the signals whatever their offset, the gyros' resolution of the Earth rate not
    needed).
    """
    with np.errstate(all="ignore"):  # absurd pulses (1e300) end in a reason, not in a page of warnings
        segments, notes = _detect_any(time, gyro, accel, rate_hz, site, min_static_s)
    rec = Recording(name=name, site=site, rate_hz=rate_hz, segments=segments, time=time, gyro=gyro, accel=accel)
    validate_schedule(rec)
    if any(s.is_free for s in rec.segments):  # the rests as the calibration's check of them leaves them
        rec = dataclasses.replace(refine(rec, min_rest_s=rec.dt), warnings=[])
    return rec, notes


def _detect_any(time, gyro, accel, rate_hz: float, site: Site, min_static_s: float | None):
    """:func:`detect`, and when it finds no turntable schedule, :func:`data.handling.detect_handled` (rests at any
    orientation, free moves; the changes of the signals, so that any offset works)."""
    if min_static_s is not None:
        try:
            return detect(time, gyro, accel, rate_hz, site, min_static_s)
        except InputError as exc:
            if exc.reason.startswith("no motion"):
                raise
            raise InputError(None, f"{exc.reason}; without --min-static-s, segment also tries it as a session turned "
                                   "by hand") from None
    try:
        return detect(time, gyro, accel, rate_hz, site, MIN_STATIC_S)
    except InputError as table_error:
        try:
            segments, notes = detect_handled(time, gyro, accel, rate_hz, site.g)
        except InputError as hand_error:
            if table_error.reason.startswith("no motion") or hand_error.reason.startswith("no motion"):
                raise hand_error from None  # the offset-free test of the two: its reason alone
            raise InputError(None, f"{table_error.reason}; as a session by hand: {hand_error.reason}") from None
        segments = _with_rotations(segments, notes)
        if not segments:
            raise InputError(None, f"{table_error.reason}; as a session by hand: no two rests are joined by a "
                                   "move") from None
        why = "" if table_error.reason.startswith("no motion") else f" ({table_error.reason})"  # by magnitude: offsets
        return segments, [f"no turntable schedule{why}: segmented as a session turned by hand (rests at any "
                          "orientation, free moves)"] + notes
