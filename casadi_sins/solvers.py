"""One entry point for all solvers: ``calibrate(recording, solver=...)``."""

from __future__ import annotations

from typing import Callable

from .parameters import ParameterSet
from .recording import Recording
from .result import CalibrationResult

SOLVERS = ("nlp", "ils")


def calibrate(rec: Recording, solver: str = "nlp", initial: ParameterSet | None = None,
              progress: Callable[[str], None] | None = None, **options) -> CalibrationResult:
    """Calibrate a recording with the named solver: ``"nlp"`` (CasADi/Ipopt) or ``"ils"`` (the paper's).

    BLAS is held to one thread meanwhile: the matrices are small, and threads spinning on them slow
    the solve down by several times on a loaded machine.
    """
    from threadpoolctl import threadpool_limits

    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
    with threadpool_limits(limits=1):
        if solver == "nlp":
            from .nlp import calibrate_nlp

            return calibrate_nlp(rec, initial=initial, progress=progress, **options)
        from .ils import calibrate_ils

        return calibrate_ils(rec, initial=initial, progress=progress, **options)
