"""A design from start to files: limits from the input problem, the search, the report, the Monte Carlo."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Callable

import numpy as np

from ...core.inputs import memory_available
from ...data.problem import Problem
from .. import montecarlo as MC
from ..consistency import consistency
from .criteria import Criterion
from .problemfile import checked_text
from .report import drawing, markdown
from .search import Candidate, design
from .space import DesignError, Limits, design_problem, peak_rate_deg_s


@dataclasses.dataclass
class DesignRun:
    """What a design run produced: the design, its problem, the files to write, the Monte Carlo summary."""

    best: Candidate
    problem: Problem
    files: dict
    verify: object = None  # pandas summary of the Monte Carlo, if run
    seconds: float = 0.0
    checks: list = dataclasses.field(default_factory=list)  # consistency of the Monte Carlo's sigma, per solver
    ils: dict | None = None  # the ILS's predicted sigma (natural) on the "input" and the "design"


def check_limits(limits: Limits) -> None:
    """One line for constraints no schedule can meet (or numbers that mean nothing)."""
    for name in ("total_s", "max_rate_deg_s"):
        value = getattr(limits, name)
        if not np.isfinite(value) or value <= 0:
            raise DesignError(f"--{name.replace('_', '-')} must be a positive number, found {value:g}")
    for name in ("min_rest_s", "first_rest_s", "handling_s"):
        value = getattr(limits, name)
        if not np.isfinite(value) or value < 0:
            raise DesignError(f"--{name.replace('_', '-')} must be 0 or more, found {value:g}")
    if not limits.angles or any(a <= 0 or a % 90 or a > 360 for a in limits.angles):
        raise DesignError("--angles must be multiples of 90 deg up to 360 (positions are letter orientations)")
    smallest = min(limits.angles)
    groups = 1 if limits.table_axes == 3 else 2
    need = groups * (max(limits.first_rest_s, limits.min_rest_s) + limits.min_rest_s + limits.rotation_s(smallest))
    need += (groups - 1) * limits.handling_s
    if limits.total_s < need:
        raise DesignError(f"--total-s {limits.total_s:g} s is too short: a {limits.table_axes}-axis table needs at "
                          f"least {need:.4g} s for its shortest usable schedule ({groups} group(s) of a first rest "
                          f"of {max(limits.first_rest_s, limits.min_rest_s):g} s, one turn of {smallest} deg at "
                          f"{limits.max_rate_deg_s:g} deg/s and a rest of {limits.min_rest_s:g} s, handling "
                          f"{limits.handling_s:g} s)")


#: Samples of one scored schedule times the schedules scored (``--evaluations``): the default search of the
#: paper's problem is 4e7 (about a minute); beyond this budget a search would take many hours.
SEARCH_BUDGET = 2e9
#: Memory one prediction holds per sample of its schedule, bytes (measured: 0.4 kB).
PREDICTION_BYTES_PER_SAMPLE = 400.0


def check_budget(limits: Limits, rate_hz: float, evaluations: int) -> None:
    """One line, naming the limit and the options, for a search beyond :data:`SEARCH_BUDGET` or beyond the
    memory its predictions need: before anything is allocated."""
    samples = limits.total_s * rate_hz
    if samples * evaluations > SEARCH_BUDGET:
        longest = SEARCH_BUDGET / evaluations / rate_hz
        raise DesignError(f"--total-s {limits.total_s:g} s at {rate_hz:g} Hz is {samples:.3g} samples per schedule "
                          f"scored, times --evaluations {evaluations}: beyond the search budget of {SEARCH_BUDGET:.3g} "
                          f"samples x evaluations (hours of search); lower --total-s (at most {longest:.0f} s with "
                          f"{evaluations} evaluations) or --evaluations")
    need, free = samples * PREDICTION_BYTES_PER_SAMPLE, memory_available()
    if need > free / 2:
        raise DesignError(f"--total-s {limits.total_s:g} s at {rate_hz:g} Hz is {samples:.3g} samples per schedule: "
                          f"its prediction needs about {need / 1e9:.3g} GB of memory, {max(free, 0.0) / 1e9:.3g} GB "
                          f"are available; lower --total-s (at most {free / 2 / PREDICTION_BYTES_PER_SAMPLE / rate_hz:.0f} s)")


def default_rate(base: Problem) -> float:
    """The input schedule's peak turn rate (deg/s): the table's rate unless told otherwise."""
    return peak_rate_deg_s(base)


def run_design(base: Problem, limits: Limits, criterion: str = "d", model: str = "21", hours: float = 1.0,
               cap: float = 1.1, evaluations: int = 300, seed: int = 0, verify_runs: int = 0, workers=None,
               out_dir: str | Path = ".", progress: Callable[[str], None] | None = None, scheme=None,
               solvers=("nlp",)) -> DesignRun:
    """Design a schedule for ``base``'s unit and prepare ``design.toml``, ``design.md`` and ``design.png``
    (and with ``verify_runs`` a Monte Carlo of the design, its files under ``verify/``); ``scheme`` (a
    rotation scheme, with ``criterion="navigation"``) scores the navigation of the modulated INS.  The
    search scores the NLP's prediction; with ``"ils"`` in ``solvers`` the report adds the ILS's own predicted
    sigma on both schedules (``DesignRun.ils``)."""
    say = progress or (lambda text: None)
    check_limits(limits)
    check_budget(limits, base.rate_hz, evaluations)
    t0 = time.perf_counter()
    crit = Criterion(criterion, base, model, cap, hours, scheme)
    say(f"input schedule {base.name}: predicted; searching under {limits.total_s:g} s")
    best = design(base, limits, crit, evaluations=evaluations, seed=seed, progress=say)
    problem = design_problem(base, best.groups, best.statics, limits, f"{base.name}-design")
    seconds = time.perf_counter() - t0
    out = Path(out_dir)
    ref = crit.score_prediction(base, crit.reference)
    settings = {"input": f"{base.name} ({base.source})", "criterion": criterion, "model": model,
                "table axes": str(limits.table_axes), "total time": f"{limits.total_s:g} s",
                "peak rate": f"{limits.max_rate_deg_s:.3g} deg/s ({limits.profile})",
                "turn angles": ", ".join(f"{a} deg" for a in limits.angles),
                "shortest rest": f"{limits.min_rest_s:g} s (first of a group {limits.first_rest_s:g} s)",
                "handling between groups": f"{limits.handling_s:g} s",
                "no parameter worse than": f"{cap:g} x the input's sigma (penalised beyond; the NLP's prediction)",
                "search": f"{crit.evaluations} predictions in {seconds:.0f} s (seed {seed})"}
    extra = []
    if criterion == "navigation":
        what = (f"largest horizontal position error over {hours:g} h under rotation scheme {scheme.name}"
                if scheme is not None else f"static free-inertial horizontal position error after {hours:g} h")
        settings["navigation"] = what + " (1 sigma, aligned at the start; calibration covariance + white noise)"
        extra.append(f"- {what}: design {crit.navigation(problem, best.score.prediction):.4g} m, input "
                     f"{crit.ref_navigation:.4g} m")
    header = (f"Designed by casadi-sins design from {base.source}: criterion {criterion}, {limits.total_s:g} s, "
              f"{limits.table_axes}-axis table.\nPredicted geometric-mean sigma ratio against {base.name} "
              f"{best.score.geometric_mean:.3f}, worst {best.score.ratios.max():.3f}.")
    files = {out / "design.toml": checked_text(problem, base, header).encode(),
             out / "design.png": drawing([base, problem])}
    summary, checks = None, []
    if verify_runs:
        summary, checks, mc_files, line = _verify(problem, best, verify_runs, workers, out, say)
        files.update(mc_files)
        extra.append(line)
    ils = None
    if "ils" in solvers:
        from ..prediction import predict_problem_ils
        say("the ILS's predicted sigma on the input and the design")
        ils = {"input": predict_problem_ils(base), "design": predict_problem_ils(problem)}
    files[out / "design.md"] = markdown(base, problem, ref, best.score, settings, extra, "design.png", ils).encode()
    return DesignRun(best, problem, files, summary, seconds, checks, ils)


#: The Monte Carlo's seeds start where ``montecarlo``'s do, so ``--verify N`` and ``montecarlo --runs N`` agree.
FIRST_SEED = 10000
SOLVERS = ("nlp", "ils")


def _verify(problem: Problem, best: Candidate, runs: int, workers, out: Path, say):
    """Monte Carlo of the design (:mod:`studies.montecarlo`, both solvers): RMS error against sigma."""
    say(f"verifying: {runs} simulated recordings of the design, each calibrated ({', '.join(SOLVERS)})")
    t0 = time.perf_counter()
    rows = MC.run(problem, range(FIRST_SEED, FIRST_SEED + runs), SOLVERS, workers)
    elapsed = time.perf_counter() - t0
    summary = MC.with_prediction(MC.summary(rows), best.score.prediction.sigma_natural)
    files = MC.montecarlo_files(problem, rows, summary, out / "verify", runs, elapsed)
    failed = int((rows["failed"] != "").sum()) if "failed" in rows else 0
    parts = []
    for solver, part in summary.groupby("solver", sort=False):
        parts.append(f"{solver}: RMS error / solver's sigma {part['rms_over_sigma'].min():.2f}-"
                     f"{part['rms_over_sigma'].max():.2f}, / predicted sigma {part['rms_over_predicted'].min():.2f}-"
                     f"{part['rms_over_predicted'].max():.2f}")
    line = f"- Monte Carlo of the design ({runs} runs, {failed} failed; verify/): " + "; ".join(parts)
    checks = consistency(rows)
    line += "".join(f"\n  - {check.line()}" for check in checks)
    return summary, checks, files, line
