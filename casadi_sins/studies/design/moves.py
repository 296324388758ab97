"""The discrete part of a design: random groups and the small changes a local search tries.

A schedule's orientation sequence is a tuple of :class:`space.GroupDesign`; a move changes one thing
(one turn's axis, sense or angle, a turn inserted or removed, two turns swapped, a group's start or
mount, a group added on tables that need remounting, a group removed or joined to the next by one more
turn) and returns a new tuple, or ``None``
when the result breaks a constraint (the shortest statics no longer fit, a mount the table cannot hold).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...data.problem import Problem
from .space import ORIENTATIONS, GroupDesign, Limits, Turn, fits, mount_allowed


def random_turn(rng: np.random.Generator, limits: Limits) -> Turn:
    """A turn about a random table axis, sense and allowed angle (90 deg twice as likely as others)."""
    axes = limits.table_turn_axes()
    weights = np.array([2.0 if a == 90 else 1.0 for a in limits.angles])
    angle = int(rng.choice(limits.angles, p=weights / weights.sum()))
    return Turn(str(rng.choice(axes)), int(rng.choice([-1, 1])), angle)


def random_mounting(rng: np.random.Generator, limits: Limits) -> tuple[str, str]:
    """A random start orientation and mount the table can hold."""
    while True:
        start, mount = str(rng.choice(ORIENTATIONS)), str(rng.choice(list("XYZ")))
        if limits.table_axes == 3:
            mount = "Z"
        if mount_allowed(start, mount, limits.table_axes):
            return start, mount


def random_group(rng: np.random.Generator, limits: Limits, n_turns: int) -> GroupDesign:
    """A random group of ``n_turns`` turns."""
    start, mount = random_mounting(rng, limits)
    return GroupDesign(start, mount, tuple(random_turn(rng, limits) for _ in range(n_turns)))


def random_design(rng: np.random.Generator, limits: Limits, n_turns: int, n_groups: int = 1):
    """A random design of ``n_groups`` groups sharing about ``n_turns`` turns, or ``None`` if it cannot fit."""
    per = max(1, n_turns // n_groups)
    groups = tuple(random_group(rng, limits, per) for _ in range(n_groups))
    return groups if fits(groups, limits) else None


def from_problem(problem: Problem, limits: Limits):
    """The input schedule as a design on a three-axis table (``None`` on other tables or angles)."""
    if limits.table_axes != 3:
        return None
    groups = []
    for plan in problem.groups:
        turns = []
        for axis, angle in plan.turns():
            sign = (1 if axis[0] == "+" else -1) * (1 if angle > 0 else -1)
            if int(abs(angle)) not in limits.angles:
                return None
            turns.append(Turn(axis[1], sign, int(abs(angle))))
        groups.append(GroupDesign(plan.start, "Z", tuple(turns)))
    groups = tuple(groups)
    return groups if fits(groups, limits) else None


def _with_turns(group: GroupDesign, turns) -> GroupDesign:
    return dataclasses.replace(group, turns=tuple(turns))


def move(groups: tuple[GroupDesign, ...], rng: np.random.Generator, limits: Limits):
    """One random change of a design; ``None`` if the result breaks a constraint."""
    kinds = ["turn", "turn", "sense", "insert", "delete", "swap", "start"]
    if limits.table_axes < 3:
        kinds += ["mount", "add group"]
    if len(groups) > 1:
        kinds += ["merge", "remove group"]
    kind = str(rng.choice(kinds))
    gi = int(rng.integers(len(groups)))
    group = groups[gi]
    turns = list(group.turns)
    k = int(rng.integers(len(turns))) if turns else 0
    if kind == "turn" and turns:
        turns[k] = random_turn(rng, limits)
    elif kind == "sense" and turns:
        turns[k] = dataclasses.replace(turns[k], sign=-turns[k].sign)
    elif kind == "insert":
        turns.insert(int(rng.integers(len(turns) + 1)), random_turn(rng, limits))
    elif kind == "delete" and turns:
        del turns[k]
    elif kind == "swap" and len(turns) > 1:
        k = min(k, len(turns) - 2)
        turns[k], turns[k + 1] = turns[k + 1], turns[k]
    elif kind in ("start", "mount"):
        start, mount = random_mounting(rng, limits)
        group = GroupDesign(start, group.mount if kind == "start" else mount, group.turns)
        if not mount_allowed(group.start, group.mount, limits.table_axes):
            return None
    elif kind == "add group":
        new = random_group(rng, limits, max(1, len(turns)))
        out = groups[: gi + 1] + (new,) + groups[gi + 1:]
        return out if fits(out, limits) else None
    elif kind == "merge" and gi + 1 < len(groups) and (limits.table_axes == 3 or group.mount == groups[gi + 1].mount):
        joined = _with_turns(group, turns + [random_turn(rng, limits)] + list(groups[gi + 1].turns))
        out = groups[:gi] + (joined,) + groups[gi + 2:]
        return out if fits(out, limits) else None
    elif kind == "remove group" and len(groups) > 1:
        out = groups[:gi] + groups[gi + 1:]
        return out if fits(out, limits) else None
    else:
        return None
    out = groups[:gi] + (_with_turns(group, turns),) + groups[gi + 1:]
    if limits.table_axes == 1 and not any(g.turns for g in out):
        return None
    return out if fits(out, limits) else None
