"""Segmentation of a session turned by hand: short rests, turns that are no exact multiples of 90 deg,
moves about several axes at once, gyros that do not resolve the Earth rate.

The turntable segmentation (:func:`data.segmentation.detect`) wants rests of 20 s, turns within 8 deg
of a multiple of 90 deg about one body axis and, for the letters' heading, the Earth rate in the
gyros.  A session by hand has none of these; the calibration does not need them either: it navigates
the true motion from the gyros, with each group's start attitude free, so a description needs the
rests (their letters right within tolerance) and a nominal turn between them.  Here:

1. rests: quiet stretches (:func:`data.edges.static_stretches`) at least the shortest rest the data
   support (:func:`data.rests.minimum_rest`'s rule) and a quarter of the longest rest (a pause within
   a move is not a position); of two rests split by an attitude jump the longer is kept;
2. the gyro pulse size: one size for the three axes that makes the gyro-integrated moves turn the
   measured gravity direction of one rest into the next's (a search over sizes; the rests' mean rate
   is taken off as the bias);
3. letters: up from gravity (within 30 deg of a body axis); the heading from the Earth rate when the
   gyros resolve it, else from the first rest by convention and along the chain of turns;
4. each move between two rests becomes the single-axis turn of a multiple of 90 deg that leads from
   the letters before to a position whose up axis is the measured one, nearest the measured travel
   about that axis; a move of less than 45 deg in all, or none that leads there, ends the group
   (handling between groups).
"""

from __future__ import annotations

import math

import numpy as np

from ..core import orientation as orient
from ..core.errors import InputError
from ..core.rotations import rotation_matrices
from .edges import activity, static_stretches
from .recording import Segment
from .rests import LEVEL_RESOLUTION, accel_noise_per_sample
from .edges import ONSET_REST_S

#: A rest lasts at least this share of the longest rest: shorter quiet stretches are pauses within a move.
REST_SHARE = 0.25
#: Gravity within this of a body axis gives the up letter.
UP_TOLERANCE_DEG = 30.0
#: A move that travels less than this in all is no turn.
MIN_TURN_DEG = 45.0


def hand_rests(gyro, accel, rate_hz: float) -> tuple[list[tuple[int, int]], float]:
    """The rests ``(first, stop)`` and the shortest rest length used (s)."""
    dt = 1.0 / rate_hz
    floor = 2.0 * ONSET_REST_S + 3 * dt
    found, jumps_at, _ = static_stretches(gyro, accel, rate_hz, floor)
    noise = accel_noise_per_sample(accel, [slice(a, b) for a, b in found])
    if math.isfinite(noise):
        floor = max(floor, (noise / LEVEL_RESOLUTION) ** 2 * dt)
    kept: list[tuple[int, int]] = []
    for a, b in found:  # of two pieces split by a jump, the longer
        if kept and kept[-1][1] == a and a in jumps_at:
            if b - a > kept[-1][1] - kept[-1][0]:
                kept[-1] = (a, b)
            continue
        kept.append((a, b))
    kept = _quiet_cores(gyro, rate_hz, kept)
    longest = max((b - a for a, b in kept), default=0) * dt
    shortest = max(floor, REST_SHARE * longest)
    return [(a, b) for a, b in kept if (b - a) * dt >= shortest], shortest


def _quiet_cores(gyro, rate_hz: float, stretches) -> list[tuple[int, int]]:
    """Each stretch cut to its longest run without motion by the rate magnitude (the test that
    :func:`data.segmentation.refine` applies to a description: a quick jerk at a rest's edge is left out)."""
    act = activity(gyro, rate_hz)
    moving = act.magnitude > act.edge
    out = []
    for a, b in stretches:
        flags = np.concatenate([[True], moving[a:b], [True]])
        edges = np.flatnonzero(np.diff(flags.astype(np.int8)))  # starts (-1) and stops (+1) of quiet runs
        runs = list(zip(edges[0::2], edges[1::2]))
        if runs:
            first, stop = max(runs, key=lambda r: r[1] - r[0])
            out.append((a + int(first), a + int(stop)))
    return out


def move_rotations(gyro, rests, biases, sizes) -> np.ndarray:
    """Body rotation of each move between consecutive rests, for each candidate pulse size: (S, M, 3, 3)."""
    out = np.tile(np.eye(3), (len(sizes), len(rests) - 1, 1, 1))
    for m in range(len(rests) - 1):
        bias = (biases[m] + biases[m + 1]) / 2.0
        for pulse in gyro[rests[m][1]:rests[m + 1][0]] - bias:
            out[:, m] = out[:, m] @ rotation_matrices(np.outer(sizes, pulse))
    return out


def gyro_pulse_size(gyro, rests, biases, ups) -> float:
    """The one gyro pulse size (rad) that best turns each rest's gravity direction into the next's."""
    paths = [float(np.sum(np.linalg.norm(gyro[rests[m][1]:rests[m + 1][0]] - biases[m], axis=1)))
             for m in range(len(rests) - 1)]
    longest = max(paths)
    if longest <= 0:
        raise InputError(None, "the gyros show no motion between the rests")
    sizes = np.geomspace(math.radians(10.0) / longest, math.radians(3600.0) / longest, 120)
    for _ in range(2):  # a coarse search, then a fine one about the best
        turns = move_rotations(gyro, rests, biases, sizes)
        predicted = np.einsum("smji,mj->smi", turns, ups[:-1])  # R^T u_k
        cost = np.sum((predicted - ups[1:]) ** 2, axis=(1, 2))
        best = sizes[int(np.argmin(cost))]
        sizes = np.geomspace(best / 1.06, best * 1.06, 25)
    return float(best)


def up_letters(up: np.ndarray) -> str | None:
    """Letters with the measured up axis and a conventional heading (the next axis North); None when gravity is
    more than :data:`UP_TOLERANCE_DEG` off every body axis."""
    j = int(np.argmax(np.abs(up)))
    if abs(up[j]) < math.cos(math.radians(UP_TOLERANCE_DEG)):
        return None
    letters = [""] * 3
    letters[j] = "U" if up[j] > 0 else "D"
    letters[(j + 1) % 3] = "N"
    for third in "EW":
        letters[(j + 2) % 3] = third
        try:
            orient.orientation_to_dcm("".join(letters))
            return "".join(letters)
        except orient.OrientationError:
            continue
    return None


def nominal_turn(before: str, up_after: np.ndarray, travel_deg: np.ndarray) -> tuple[str, float, str] | None:
    """``(axis, angle_deg, letters after)``: the single-axis turn of a multiple of 90 deg from ``before`` to a
    position whose up axis is the measured one, nearest the measured travel; None when there is none."""
    target = up_letters(up_after)
    if target is None or float(np.linalg.norm(travel_deg)) < MIN_TURN_DEG:
        return None
    j = next(i for i, c in enumerate(target) if c in "UD")
    best = None
    for i in range(3):
        for sign in (1.0, -1.0):
            for quarter in (1, 2, 3, 4):
                axis = f"{'+' if sign > 0 else '-'}{'XYZ'[i]}"
                after = orient.dcm_to_orientation(
                    orient.rotate_body(orient.orientation_to_dcm(before), axis, math.radians(90.0 * quarter)), 1.0)
                if after[j] != target[j]:
                    continue
                miss = abs(travel_deg[i] - sign * 90.0 * quarter) + float(np.linalg.norm(np.delete(travel_deg, i)))
                if best is None or miss < best[0]:
                    best = (miss, axis, 90.0 * quarter, after)
    return None if best is None else best[1:]


def detect_handled(time, gyro, accel, rate_hz: float) -> tuple[list[Segment], list[str]]:
    """The segments of a session turned by hand (module docstring), and notes on what was assumed.

    Raises
    ------
    InputError
        When fewer than two rests, or no two rests joined by a turn, are found.
    """
    dt = 1.0 / rate_hz
    rests, shortest = hand_rests(gyro, accel, rate_hz)
    if len(rests) < 2:
        raise InputError(None, f"fewer than two rests of at least {shortest:.3g} s: no schedule")
    biases = np.array([gyro[a:b].mean(axis=0) for a, b in rests])
    ups = np.array([accel[a:b].mean(axis=0) for a, b in rests])
    ups /= np.linalg.norm(ups, axis=1, keepdims=True)
    size = gyro_pulse_size(gyro, rests, biases, ups)
    notes = [f"rests of at least {shortest:.3g} s (a quarter of the longest, and what the edges and the noise "
             f"need); gyro pulse size {size:.6g} rad from the gravity directions the moves turn; letters' heading "
             "by convention along the chain of turns (the Earth rate is not used)"]
    segments: list[Segment] = []
    group, letters = 0, None
    for k, (a, b) in enumerate(rests):
        start, end = round(float(time[a] - dt), 9), round(float(time[b - 1]), 9)
        turn = None
        if letters is not None:
            travel = np.degrees(size * (gyro[rests[k - 1][1]:a] - (biases[k - 1] + biases[k]) / 2.0).sum(axis=0))
            turn = nominal_turn(letters, ups[k], travel)
            if turn is None:
                notes.append(f"{time[rests[k - 1][1]]:.2f}-{start:.2f} s: no turn of a multiple of 90 deg leads to the "
                             "next rest's gravity: handling between groups")
        if turn is None:
            letters = up_letters(ups[k])
            if letters is None:
                notes.append(f"{start:.2f}-{end:.2f} s: gravity is off every body axis by more than "
                             f"{UP_TOLERANCE_DEG:g} deg: left out")
                continue
            group += 1
        else:
            axis, angle, letters = turn
            segments.append(Segment(len(segments) + 1, group, "rotation", segments[-1].end, start, axis=axis,
                                    angle_deg=angle))
        segments.append(Segment(len(segments) + 1, group, "static", start, end, orientation=letters))
    return segments, notes
