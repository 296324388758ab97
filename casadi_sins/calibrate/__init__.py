"""Calibration of a recording: ``calibrate(recording, solver="nlp" | "ils")``.

The NLP (:mod:`calibrate.nlp`) solves the whole fit as one nonlinear least-squares problem with
CasADi and Ipopt; the ILS (:mod:`calibrate.ils`) is the paper's iterative linear least squares, the
reference.  Both return a :class:`CalibrationResult` or raise :class:`CalibrationError`.

:func:`calibrate` first checks the static segments against the data (:func:`data.segmentation.refine`):
motion at a static segment's edge is trimmed off and said so in ``result.warnings`` (never left to look
like a swaying base), motion inside one is an :class:`~core.errors.InputError` naming it.
"""

from __future__ import annotations

from typing import Callable

from ..core.threads import single_threaded
from ..data.recording import Recording
from ..data.rests import RestRule, minimum_rest
from ..data.segmentation import refine
from ..model.parameters import ParameterSet
from .ils import calibrate_ils
from .nlp.pipeline import calibrate_nlp
from .result import CalibrationError, CalibrationResult, Check
from .trust import implausible

SOLVERS = ("nlp", "ils")

__all__ = ["SOLVERS", "CalibrationError", "CalibrationResult", "calibrate", "calibrate_ils", "calibrate_nlp",
           "prepare_compiled"]


def calibrate(rec: Recording, solver: str = "nlp", initial: ParameterSet | None = None,
              progress: Callable[[str], None] | None = None, refine_segments: bool = True,
              min_rest_s: float | None = None, **options) -> CalibrationResult:
    """Calibrate a recording with the named solver: ``"nlp"`` (CasADi/Ipopt) or ``"ils"`` (the paper's).

    Parameters
    ----------
    rec : Recording
    solver : {"nlp", "ils"}
    initial : ParameterSet, optional
        Starting values (default: the paper's rough values, section 1.3).
    progress : callable, optional
        Receives one line per stage or iteration.
    refine_segments : bool
        Check the static segments against the data first (:func:`data.segmentation.refine`, a few
        milliseconds per minute of data): motion at an edge is trimmed off, with a warning that says
        so; ``False`` takes the segment times as they are.
    min_rest_s : float, optional
        The shortest rest a static segment must keep (default: from the measured noise and rate,
        :func:`data.rests.minimum_rest`); the result's checks state it and the shortest rest found.
    **options
        Passed to :func:`calibrate_nlp` or :func:`calibrate_ils`.

    Notes
    -----
    BLAS is held to one thread meanwhile: the matrices are small, and threads spinning on them slow
    the solve down by several times on a loaded machine.

    Raises
    ------
    InputError
        When a static segment holds motion inside it (not only at an edge).
    CalibrationError
        When the calibration cannot give a table.  A table its own checks do not trust is returned with the
        reasons in ``result.distrust`` (:mod:`calibrate.trust`): the command line does not write it as a
        parameter table unless told to.
    """
    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
    rule = minimum_rest(rec, min_rest_s)
    if refine_segments:
        trimmed = refine(rec, rule.seconds if rule.stated else None)
        if progress is not None and trimmed is not rec:
            for message in trimmed.warnings[len(rec.warnings):]:
                progress(message)
        rec = trimmed
    with single_threaded():
        if solver == "nlp":
            result = calibrate_nlp(rec, initial=initial, progress=progress, **options)
        else:
            result = calibrate_ils(rec, initial=initial, progress=progress, **options)
    result.checks.append(rest_check(rec, rule))
    result.distrust += implausible(result.parameters, result.initial)
    return result


def rest_check(rec: Recording, rule: RestRule) -> Check:
    """The shortest static segment against the shortest rest accepted, with the rule's reason (a check of the
    report: the minimum is stated, never a bare limit)."""
    shortest = min(rec.static_segments, key=lambda s: s.end - s.start)
    length = shortest.end - shortest.start
    return Check("shortest rest", float(length), float(rule.seconds), length >= rule.seconds,
                 f"shortest static segment {length:.3g} s: {shortest.describe()}; shortest rest accepted "
                 f"{rule.reason}", at_least=True)


def prepare_compiled(model="21", bias_instability: bool = False) -> None:
    """Compile (or load from the cache) the functions a calibration runs: the strapdown step and its tangent
    for the parameter model, the error model, and the Kalman filter of the noise model's state layout.

    Parallel workers then find them compiled instead of compiling the same libraries at once (the first
    run with an empty cache compiles for a few seconds per library; later ones load them in milliseconds).
    ``bias_instability``: also the filter with Gauss-Markov biases (a datasheet's instability, or a wander
    the static data may show when no datasheet gives one).
    """
    from ..model.registry import model_names
    from ..nav.errormodel import sensitivity_chain
    from ..nav.navigation import navigation_chain
    from ..nav.tangent import step_blocks
    from ..noise.filter import FILTER_COLUMNS, filter_chain, transition_pattern
    from ..noise.statespace import Layout
    from .nlp.selection import model_groups

    navigation_chain()
    sensitivity_chain()
    step_blocks(model_names(model_groups(model)))
    for layout in [Layout(False, False)] + ([Layout(True, False)] if bias_instability else []):
        for columns in (1, FILTER_COLUMNS):
            filter_chain(layout.n, columns, transition_pattern(layout).tobytes())
