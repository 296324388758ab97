"""One entry point for all solvers: ``calibrate(recording, solver=...)``."""

from __future__ import annotations

from typing import Callable

from .parameters import ParameterSet
from .recording import Recording
from .result import CalibrationResult

SOLVERS = ("nlp", "ils")


def calibrate(rec: Recording, solver: str = "nlp", initial: ParameterSet | None = None,
              progress: Callable[[str], None] | None = None, **options) -> CalibrationResult:
    """Calibrate a recording with the named solver: ``"nlp"`` (CasADi/Ipopt) or ``"ils"`` (the paper's)."""
    if solver == "nlp":
        from .nlp import calibrate_nlp

        return calibrate_nlp(rec, initial=initial, progress=progress, **options)
    if solver == "ils":
        from .ils import calibrate_ils

        return calibrate_ils(rec, initial=initial, progress=progress, **options)
    raise ValueError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
