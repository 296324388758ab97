"""What a calibration table can do: its axes, the turns they make, and the time a schedule takes.

A schedule is a sequence of groups.  Each group is one mounting of the unit on the table: a start
orientation (three letters, :mod:`core.orientation`), the body axis on the table's inner axis (the
*mount*), and a sequence of turns about the table's axes.  The table's axes decide which body axes a
turn can be about:

``3`` axes
    any body axis (a three-axis table reaches every orientation and turns about each body axis);
``2`` axes
    the inner axis, fixed in the body (the mount), and the outer axis, fixed on the ground along a
    horizontal direction (``OUTER``): a turn about it is about the body axis that lies along it at
    that moment.  The mount stays perpendicular to the outer axis;
``1`` axis
    the inner axis only: other orientations need a new mounting, a new group.

Between groups the unit is handled (remounted or moved by the table) in a stated time that counts
against the budget.  Turns are about one axis with the input schedule's rate profile; each turn takes
the time its angle needs at the rate limit (the problem format's ``rotations_s``).  Positions are
always letter orientations: the recording format names them so.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...core.orientation import DIRECTIONS, orientation_to_dcm, rotate_body
from ...data.problem import GroupPlan, Problem

#: Peak rate of a turn per mean rate (angle / time) for each rate profile: half-sine pi/2, versine 2.
PEAK_PER_MEAN = {"half-sine": math.pi / 2.0, "versine": 2.0}
#: The ground direction of a two-axis table's outer axis.
OUTER = "N"
#: Every letter orientation (24): right-handed triples of N S E W U D.
ORIENTATIONS = tuple(a + b + c for a in "NSEWUD" for b in "NSEWUD" for c in "NSEWUD"
                     if abs(np.linalg.det(np.column_stack([DIRECTIONS[x] for x in (a, b, c)])) - 1.0) < 1e-9)


class DesignError(ValueError):
    """Constraints no schedule can meet (told in one line)."""


@dataclasses.dataclass(frozen=True)
class Turn:
    """One turn: the table axis (``"X"``, ``"Y"``, ``"Z"`` body axes of a 3-axis table, or ``"inner"`` /
    ``"outer"``), its sense (+1 / -1) and its angle (deg)."""

    axis: str
    sign: int
    angle: int


@dataclasses.dataclass(frozen=True)
class GroupDesign:
    """One mounting: start orientation, the body axis on the inner table axis, the turns."""

    start: str
    mount: str
    turns: tuple[Turn, ...]


@dataclasses.dataclass(frozen=True)
class Limits:
    """The constraints of a design (SI seconds, deg/s).

    Attributes
    ----------
    total_s : float
        Statics plus turns plus handling, at most.
    max_rate_deg_s : float
        Peak rate of a turn.
    min_rest_s, first_rest_s : float
        Shortest static; shortest first static of a group (the alignment's).
    handling_s : float
        Time to handle the unit between two groups.
    angles : tuple of int
        Turn angles allowed (deg, multiples of 90).
    table_axes : int
    profile : str
        The turns' rate profile (the input schedule's).
    """

    total_s: float
    max_rate_deg_s: float
    min_rest_s: float = 30.0
    first_rest_s: float = 60.0
    handling_s: float = 60.0
    angles: tuple[int, ...] = (90, 180)
    table_axes: int = 3
    profile: str = "half-sine"

    def rotation_s(self, angle_deg: float) -> float:
        """Time of a turn of ``angle_deg`` at the rate limit (peak rate = limit), rounded up to 1 ms."""
        return math.ceil(PEAK_PER_MEAN[self.profile] * angle_deg / self.max_rate_deg_s * 1000.0 - 1e-6) / 1000.0

    def table_turn_axes(self) -> tuple[str, ...]:
        """The table axes a turn can be about."""
        return {3: ("X", "Y", "Z"), 2: ("inner", "outer"), 1: ("inner",)}[self.table_axes]


def body_axis(turn: Turn, mount: str, dcm: np.ndarray) -> str:
    """The signed body axis (``"+X"`` ... ``"-Z"``) of a turn at attitude ``dcm`` (``C_b^n``)."""
    if turn.axis in "XYZ":
        letter, sign = turn.axis, turn.sign
    elif turn.axis == "inner":
        letter, sign = mount, turn.sign
    else:  # the outer axis, fixed on the ground: the body axis along it now
        body = dcm.T @ DIRECTIONS[OUTER]
        k = int(np.argmax(np.abs(body)))
        letter, sign = "XYZ"[k], turn.sign * int(np.sign(body[k]))
    return ("+" if sign > 0 else "-") + letter


def mount_allowed(start: str, mount: str, table_axes: int) -> bool:
    """Whether a mounting is possible: on a two-axis table the mount is perpendicular to the outer axis."""
    if table_axes != 2:
        return True
    direction = orientation_to_dcm(start)[:, "XYZ".index(mount)]
    return abs(float(direction @ DIRECTIONS[OUTER])) < 0.5


def group_plan(group: GroupDesign, statics_s, limits: Limits) -> GroupPlan:
    """A designed group in the problem format (body axes, angles, each static's and each turn's duration)."""
    dcm = orientation_to_dcm(group.start)
    rotations = []
    for turn in group.turns:
        axis = body_axis(turn, group.mount, dcm)
        rotations.append(f"{axis} {turn.angle}")
        dcm = np.round(rotate_body(dcm, axis, math.radians(turn.angle)))
    return GroupPlan(group.start, tuple(rotations), 90.0, tuple(float(t) for t in statics_s),
                     turn_times(group, limits) or None)


def vertical_axes(groups: tuple[GroupDesign, ...]) -> set[int]:
    """The body axes (0, 1, 2) that point up or down in some static position of a design."""
    out = set()
    for g in groups:
        dcm = orientation_to_dcm(g.start)
        out.add(int(np.argmax(np.abs(dcm[2]))))
        for turn in g.turns:
            dcm = np.round(rotate_body(dcm, body_axis(turn, g.mount, dcm), math.radians(turn.angle)))
            out.add(int(np.argmax(np.abs(dcm[2]))))
    return out


def usable(groups: tuple[GroupDesign, ...]) -> bool:
    """Whether the calibration can start from a design: every accelerometer axis sees gravity in some static
    (the rough scale factors of :mod:`calibrate.initial` need it)."""
    return len(vertical_axes(groups)) == 3


def turn_times(group: GroupDesign, limits: Limits) -> tuple[float, ...]:
    """The time each turn of a group takes (s): its angle's at the rate limit."""
    return tuple(limits.rotation_s(t.angle) for t in group.turns)


def static_budget(groups: tuple[GroupDesign, ...], limits: Limits) -> float:
    """Time left for the statics (s): the total less the turns and the handling."""
    turning = sum(sum(turn_times(g, limits)) for g in groups)
    return limits.total_s - turning - (len(groups) - 1) * limits.handling_s


def minimum_rests(groups: tuple[GroupDesign, ...], limits: Limits) -> list[np.ndarray]:
    """Per group the shortest duration of each static (the first one the alignment's)."""
    out = []
    for g in groups:
        low = np.full(len(g.turns) + 1, limits.min_rest_s)
        low[0] = max(limits.first_rest_s, limits.min_rest_s)
        out.append(low)
    return out


def fits(groups: tuple[GroupDesign, ...], limits: Limits) -> bool:
    """Whether the shortest statics of a design fit in its static budget."""
    return static_budget(groups, limits) >= sum(float(low.sum()) for low in minimum_rests(groups, limits)) - 1e-9


def equal_statics(groups: tuple[GroupDesign, ...], limits: Limits) -> list[np.ndarray]:
    """Static durations sharing the budget equally, each at least its minimum (whole seconds/10)."""
    lows = minimum_rests(groups, limits)
    flat = np.concatenate(lows)
    budget = static_budget(groups, limits)
    level = max(budget / len(flat), 0.0)
    for _ in range(len(flat)):  # water filling: statics under their minimum are held there
        times = np.maximum(flat, level)
        free = times > flat
        if not free.any():
            break
        level = (budget - flat[~free].sum()) / free.sum()
    times = np.maximum(flat, level)
    return split(times, groups)


def split(flat: np.ndarray, groups: tuple[GroupDesign, ...]) -> list[np.ndarray]:
    """Per-group arrays of static durations from one flat array."""
    sizes = np.cumsum([len(g.turns) + 1 for g in groups])[:-1]
    return [np.asarray(part, float) for part in np.split(np.asarray(flat, float), sizes)]


def design_problem(base: Problem, groups: tuple[GroupDesign, ...], statics: list[np.ndarray], limits: Limits,
                   name: str | None = None) -> Problem:
    """The design as a problem: ``base``'s unit, noise, site and truth with the designed schedule (statics
    rounded down to 0.1 s, so the whole stays within the budget)."""
    plans = tuple(group_plan(g, np.floor(np.asarray(t) * 10.0 + 1e-6) / 10.0, limits)
                  for g, t in zip(groups, statics))
    longest = max((s for g in groups for s in turn_times(g, limits)), default=limits.rotation_s(90))
    timing = dataclasses.replace(base.timing, rotation_s=longest,
                                 gap_s=float(limits.handling_s) if len(groups) > 1 else 0.0, first_static_s=None,
                                 static_s=float(np.mean(np.concatenate(statics))))
    return dataclasses.replace(base, name=name or f"{base.name}-design", groups=plans, timing=timing, source=None,
                               description="designed schedule (casadi-sins design)")


def peak_rate_deg_s(problem: Problem) -> float:
    """The peak turn rate of a problem's schedule (deg/s): the fastest of its turns (angle over duration)."""
    mean = [abs(s.angle_deg) / (s.end - s.start) for s in problem.segments() if s.kind == "rotation"]
    return PEAK_PER_MEAN[problem.timing.rate_profile] * (max(mean) if mean else 90.0 / problem.timing.rotation_s)
