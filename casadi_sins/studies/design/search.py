"""The design search: orientation sequences by simulated annealing, then the dwell times by gradient.

1. Screening: the input schedule and the published 19-position scheme re-timed to the limits (on a
   three-axis table), and random designs with between half and twice as many turns as the input
   (``SCREEN_SHARE`` of the evaluations).  Every candidate is scored with its statics sharing the
   time budget equally (:func:`space.equal_statics`), by the criterion on the predicted covariance
   (:mod:`.criteria`).  Random designs are a strong start: the criterion varies widely between them.
2. From the input, the published schedule and the best ``chains`` random ones a chain of simulated
   annealing runs over the moves of :mod:`.moves` (one change at a time; worse candidates accepted with probability
   ``exp(-delta / T)``, ``T`` falling geometrically from ``T_START`` to ``T_END``).
3. The best orientation sequence found gets its dwell times optimised (:mod:`.dwell`).

Every prediction is deterministic (noise-free simulation at the problem's truth), so a cache by
schedule avoids repeating one.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from ...data.problem import Problem, default_problem_path, load_problem
from .criteria import Criterion, Score
from .dwell import optimise_dwell
from .moves import from_problem, move, random_design
from .space import DesignError, GroupDesign, Limits, design_problem, equal_statics, minimum_rests, split, usable

T_START, T_END = 0.03, 0.002
#: Share of the evaluations spent screening random designs before the annealing starts from the best.
SCREEN_SHARE = 0.25
#: Published schedules shipped with the package that seed the search too (on a three-axis table).
PUBLISHED = ("xie2011-19pos.toml",)


def published_schedules() -> list[Problem]:
    """The shipped published schedules (:data:`PUBLISHED`) as problems."""
    folder = default_problem_path().parent
    return [load_problem(folder / name) for name in PUBLISHED]


@dataclasses.dataclass
class Candidate:
    """A schedule: its orientation sequence, static durations and score."""

    groups: tuple[GroupDesign, ...]
    statics: list[np.ndarray]
    score: Score


class Designer:
    """Scores schedules of one problem under one set of limits and one criterion (cached)."""

    def __init__(self, base: Problem, limits: Limits, criterion: Criterion):
        self.base, self.limits, self.criterion = base, limits, criterion
        self.cache: dict = {}

    def problem(self, groups, statics, name=None) -> Problem:
        return design_problem(self.base, groups, statics, self.limits, name)

    def evaluate(self, groups: tuple[GroupDesign, ...], statics: list[np.ndarray] | None = None) -> Candidate:
        """Score a schedule (equal statics unless given)."""
        statics = equal_statics(groups, self.limits) if statics is None else statics
        key = (groups, tuple(np.floor(np.concatenate(statics) * 10.0 + 1e-6)))
        if key not in self.cache and not usable(groups):  # the calibration would refuse it: not predicted
            self.cache[key] = None
        if key not in self.cache:
            try:
                score = self.criterion.score(self.problem(groups, statics))
            except (ValueError, np.linalg.LinAlgError):  # a schedule the estimator cannot use
                score = None
            self.cache[key] = score
        score = self.cache[key]
        if score is None:
            return Candidate(groups, statics, Score(None, np.full(1, np.inf), np.inf, np.inf))
        return Candidate(groups, statics, score)

    def seeds(self, rng: np.random.Generator, count: int) -> tuple[list[Candidate], list[Candidate]]:
        """The input schedule and the published ones (if the table can make them), and ``count`` random
        designs, best first."""
        own = []
        for problem in (self.base, *published_schedules()):
            groups = from_problem(problem, self.limits)
            if groups is not None and groups not in [c.groups for c in own]:
                own.append(self.evaluate(groups))
        out = []
        n_turns = max(sum(len(g.rotations) for g in self.base.groups), 3)
        n_groups = 1 if self.limits.table_axes == 3 else {1: 3, 2: 2}[self.limits.table_axes]
        tries, made = 0, 0
        while made < count and tries < 50 * count:
            tries += 1
            groups = random_design(rng, self.limits, int(rng.integers(max(2, n_turns // 2), 2 * n_turns + 1)),
                                   n_groups)
            if groups is not None:
                out.append(self.evaluate(groups))
                made += 1
        if not out and not own:
            raise DesignError("no schedule fits: the time budget is too short for the turns, rests and handling")
        return own, sorted(out, key=lambda c: c.score.objective)

    def anneal(self, start: Candidate, rng: np.random.Generator, evaluations: int,
               progress: Callable[[Candidate], None]) -> Candidate:
        """One chain of simulated annealing from ``start``; the best candidate it met."""
        current = best = start
        for k in range(evaluations):
            temperature = T_START * (T_END / T_START) ** (k / max(evaluations - 1, 1))
            groups = None
            for _ in range(20):
                groups = move(current.groups, rng, self.limits)
                if groups is not None:
                    break
            if groups is None:
                continue
            cand = self.evaluate(groups)
            delta = cand.score.objective - current.score.objective
            if not np.isfinite(current.score.objective) or delta < 0 or rng.random() < np.exp(-delta / temperature):
                current = cand
            if cand.score.objective < best.score.objective:
                best = cand
            progress(best)
        return best

    def dwell(self, cand: Candidate, iterations: int, progress: Callable[[str], None] | None) -> Candidate:
        """Optimise a candidate's dwell times."""
        low = np.concatenate(minimum_rests(cand.groups, self.limits))

        def objective(flat):
            return self.evaluate(cand.groups, split(flat, cand.groups)).score.objective

        flat, _ = optimise_dwell(np.concatenate(cand.statics), low, objective, iterations, progress)
        return self.evaluate(cand.groups, split(flat, cand.groups))


def design(base: Problem, limits: Limits, criterion: Criterion, evaluations: int = 300, chains: int = 1,
           seed: int = 0, dwell_iterations: int = 4, finalists: int = 1,
           progress: Callable[[str], None] | None = None) -> Candidate:
    """Search a schedule for ``base``'s unit under ``limits`` minimising ``criterion``.

    Parameters
    ----------
    evaluations : int
        Orientation sequences scored in all (spread over ``chains`` chains).
    finalists : int
        Best distinct sequences whose dwell times are optimised.

    Raises
    ------
    DesignError
        When no schedule fits the limits.
    """
    say = progress or (lambda text: None)
    designer = Designer(base, limits, criterion)
    rng = np.random.default_rng(seed)
    screened = max(chains, int(SCREEN_SHARE * evaluations))
    own, screened_designs = designer.seeds(rng, screened)
    starts = own + screened_designs[:chains]  # the input's chain is kept: joining its groups may pay
    seeds = sorted(starts + screened_designs[chains:], key=lambda c: c.score.objective)
    say(f"screened {len(own) + len(screened_designs)} schedules (the input, published and random ones): best "
        f"objective {seeds[0].score.objective:+.4f}; annealing from {len(starts)}")
    found: list[Candidate] = list(starts)
    done = [0]
    overall = [seeds[0]]
    budget = max(evaluations - screened, chains)

    def report(best: Candidate) -> None:
        done[0] += 1
        if best.score.objective < overall[0].score.objective:
            overall[0] = best
        if done[0] % 25 == 0 or done[0] == budget:
            top = overall[0].score
            say(f"orientation search: {done[0]}/{budget} schedules, best objective {top.objective:+.4f} "
                f"(geometric-mean sigma ratio {top.geometric_mean:.3f}, worst {top.ratios.max():.3f})")

    per_chain = max(1, budget // len(starts))
    for start in starts:
        found.append(designer.anneal(start, rng, per_chain, report))
    found.sort(key=lambda c: c.score.objective)
    distinct = list({c.groups: c for c in found}.values())[:finalists]
    finals = [designer.dwell(c, dwell_iterations, say) for c in distinct]
    best = min(finals + found, key=lambda c: c.score.objective)
    if not np.isfinite(best.score.objective):
        raise DesignError(f"no usable schedule found in {evaluations} evaluations (every accelerometer axis must point "
                          "up or down in some static): give more --evaluations, or a longer --total-s")
    return best
