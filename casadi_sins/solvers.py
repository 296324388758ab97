"""One entry point for all solvers: ``calibrate(recording, solver=...)``."""

from __future__ import annotations

from typing import Callable

from .parameters import ParameterSet
from .recording import Recording
from .result import CalibrationResult

SOLVERS = ("ils",)


def calibrate(rec: Recording, solver: str = "ils", initial: ParameterSet | None = None,
              progress: Callable[[str], None] | None = None, **options) -> CalibrationResult:
    """Calibrate a recording with the named solver (``"ils"``)."""
    if solver == "ils":
        from .ils import calibrate_ils

        return calibrate_ils(rec, initial=initial, progress=progress, **options)
    raise ValueError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
