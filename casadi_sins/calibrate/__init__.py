"""Calibration of a recording: ``calibrate(recording, solver="nlp" | "ils")``.

The NLP (:mod:`calibrate.nlp`) solves the whole fit as one nonlinear least-squares problem with
CasADi and Ipopt; the ILS (:mod:`calibrate.ils`) is the paper's iterative linear least squares, the
reference.  Both return a :class:`CalibrationResult` or raise :class:`CalibrationError`.
"""

from __future__ import annotations

from typing import Callable

from ..core.threads import single_threaded
from ..data.recording import Recording
from ..model.parameters import ParameterSet
from .ils import calibrate_ils
from .nlp.pipeline import calibrate_nlp
from .result import CalibrationError, CalibrationResult

SOLVERS = ("nlp", "ils")

__all__ = ["SOLVERS", "CalibrationError", "CalibrationResult", "calibrate", "calibrate_ils", "calibrate_nlp"]


def calibrate(rec: Recording, solver: str = "nlp", initial: ParameterSet | None = None,
              progress: Callable[[str], None] | None = None, **options) -> CalibrationResult:
    """Calibrate a recording with the named solver: ``"nlp"`` (CasADi/Ipopt) or ``"ils"`` (the paper's).

    Parameters
    ----------
    rec : Recording
    solver : {"nlp", "ils"}
    initial : ParameterSet, optional
        Starting values (default: the paper's rough values, section 1.3).
    progress : callable, optional
        Receives one line per stage or iteration.
    **options
        Passed to :func:`calibrate_nlp` or :func:`calibrate_ils`.

    Notes
    -----
    BLAS is held to one thread meanwhile: the matrices are small, and threads spinning on them slow
    the solve down by several times on a loaded machine.
    """
    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
    with single_threaded():
        if solver == "nlp":
            return calibrate_nlp(rec, initial=initial, progress=progress, **options)
        return calibrate_ils(rec, initial=initial, progress=progress, **options)
