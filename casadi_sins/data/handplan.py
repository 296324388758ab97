"""The ``[hand]`` table of a problem file: a session by hand to simulate (:mod:`sim.hand`).

::

    [hand]
    rests = 36                   # rests, the first included
    first_rest_s = 40.0
    rest_s = [3.0, 10.0]         # each later rest's duration, uniform
    move_s = [3.0, 8.0]          # each move's duration
    peak_rate_deg_s = [60.0, 250.0]
    translation_m = [0.05, 0.3]
    settle_deg = 1.0             # the end of each move crept into the rest, over settle_s
    settle_s = 0.25
    tremor_deg = 0.02            # rms angle and linear acceleration of the hand's tremor in the rests
    tremor_mg = 2.0
    tremor_hz = [6.0, 12.0]
    clock_jitter = 0.0           # rms of the true sample instants about the nominal ones, in sample intervals
    cone_deg = 180.0             # every rest's gravity within this of the first rest's
    layout_seed = 0              # the schedule's durations; the motion from the simulation's seed
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.errors import InputError, shown
from .recording import Segment


@dataclasses.dataclass(frozen=True)
class HandPlan:
    """A session by hand (``[hand]``): rests at random orientations joined by free moves.

    Durations and ranges are drawn uniformly; the schedule (how long each rest and move lasts) from
    ``layout_seed``, so that it is the same for every simulation seed; the orientations, the moves' paths,
    the translations and the tremor from the simulation's seed (:mod:`sim.hand`).
    """

    rests: int = 36  # rests, the first included
    first_rest_s: float = 40.0
    rest_s: tuple[float, float] = (4.0, 10.0)
    move_s: tuple[float, float] = (3.0, 8.0)
    peak_rate_deg_s: tuple[float, float] = (60.0, 250.0)  # each move's peak rate (its path wobbles to reach it)
    translation_m: tuple[float, float] = (0.05, 0.3)  # how far each move carries the unit
    settle_deg: float = 1.0  # the last part of each move, crept into the rest (rate fading over a fraction of a second)
    settle_s: float = 0.25
    tremor_deg: float = 0.02  # rms angle of the hand's tremor in the rests
    tremor_mg: float = 2.0  # rms linear acceleration of the tremor
    tremor_hz: tuple[float, float] = (6.0, 12.0)
    clock_jitter: float = 0.0  # rms of the true sample instants about the nominal ones, in sample intervals
    cone_deg: float = 180.0  # every rest's gravity within this of the first rest's (less than 180: a poor session)
    layout_seed: int = 0

    def segments(self) -> list[Segment]:
        """The schedule: rests at any orientation and free moves, one group, from 0 s."""
        rests, moves = self.durations()
        segs, t = [], 0.0
        for k, rest in enumerate(rests):
            if k:
                segs.append(Segment(len(segs) + 1, 1, "rotation", round(t, 9), round(t + moves[k - 1], 9)))
                t += moves[k - 1]
            segs.append(Segment(len(segs) + 1, 1, "static", round(t, 9), round(t + rest, 9)))
            t += rest
        return segs

    def durations(self) -> tuple[list[float], list[float]]:
        """``(rests, moves)``: each rest's and move's duration (s), from ``layout_seed``."""
        rng = np.random.default_rng(self.layout_seed)
        rests = [self.first_rest_s] + list(rng.uniform(*self.rest_s, size=self.rests - 1))
        moves = list(rng.uniform(*self.move_s, size=self.rests - 1))
        return [float(r) for r in rests], [float(m) for m in moves]


def _number(value, path, where: str) -> float:
    """A finite number, or the refusal naming ``[hand] key``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(path, f"[{where.split()[0]}] {where.split()[-1]} must be a finite number, found {shown(value)}")
    return float(value)


def read_hand_plan(doc, path) -> HandPlan | None:
    """A problem file's ``[hand]`` table, or None without one.

    Raises
    ------
    InputError
        Naming the file and the key at fault.
    """
    if doc is None:
        return None
    if not isinstance(doc, dict):
        raise InputError(path, "[hand] must be a table")
    fields = {f.name: f.default for f in dataclasses.fields(HandPlan)}
    unknown = set(doc) - set(fields)
    if unknown:
        raise InputError(path, f"[hand] unknown key(s) {', '.join(sorted(unknown))}")
    values = {}
    for key, value in doc.items():
        if isinstance(fields[key], tuple):
            pair = value if isinstance(value, list) else [value, value]
            if len(pair) != 2:
                raise InputError(path, f"[hand] {key} must be a number or [low, high]")
            low, high = (_number(v, path, f"hand {key}") for v in pair)
            if not 0.0 <= low <= high:
                raise InputError(path, f"[hand] {key} must be 0 <= low <= high")
            values[key] = (low, high)
        elif key in ("rests", "layout_seed"):
            count = _number(doc[key], path, f"hand {key}")
            if count != int(count) or count < (2 if key == "rests" else 0):
                raise InputError(path, f"[hand] {key} must be an integer" + (" of at least 2" if key == "rests" else ""))
            values[key] = int(count)
        else:
            number = _number(doc[key], path, f"hand {key}")
            if number < 0.0:
                raise InputError(path, f"[hand] {key} must not be negative")
            values[key] = number
    plan = HandPlan(**values)
    if min(plan.first_rest_s, plan.rest_s[0], plan.move_s[0]) <= 0.0 or plan.peak_rate_deg_s[1] <= 0.0:
        raise InputError(path, "[hand] rests, moves and peak rates must be positive")
    return plan
