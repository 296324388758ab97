"""What every solver returns: one interface for the CLI, the comparison and the Monte Carlo."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from . import parameters as P


class CalibrationError(RuntimeError):
    """A calibration that cannot give a trustworthy parameter table (no convergence, rank deficiency)."""


@dataclasses.dataclass
class CalibrationResult:
    """Outcome of a calibration.

    Attributes
    ----------
    solver : str
        ``"ils"`` (the paper's iterative least squares) or ``"nlp"``.
    parameters : ParameterSet
        Estimate with its covariance (SI).
    initial : ParameterSet
        Starting values (the paper's rough initial values unless given).
    history : list of ndarray
        Parameter vector after each iteration (index 0: initial).
    iterations : int
    converged : bool
    residual_rms : float
        RMS of the whitened residuals (1 for a noise model that fits).
    wall_time : float
        Seconds from recording to parameter table.
    sigma_meaning : str
        What ``sigma`` in the table stands for.
    info : dict
        Solver-specific details (per-iteration corrections, timings, ...).
    """

    solver: str
    parameters: P.ParameterSet
    initial: P.ParameterSet
    history: list[np.ndarray]
    iterations: int
    converged: bool
    residual_rms: float
    wall_time: float
    sigma_meaning: str = ""
    info: dict = dataclasses.field(default_factory=dict)

    def history_frame(self, truth: P.ParameterSet | None = None) -> pd.DataFrame:
        """Parameters x iterations, shaped like the paper's Table 2 (values; errors in natural units with truth)."""
        names = self.parameters.names
        frame = pd.DataFrame({"parameter": names, "unit": self.parameters.units})
        history = [np.asarray(v)[: len(names)] for v in self.history]
        for k, values in enumerate(history):
            label = "initial" if k == 0 else f"iteration {k}"
            frame[label] = values
        if truth is not None:
            reference = truth.aligned(names)
            frame["truth"] = reference
            frame["error unit"] = self.parameters.natural_units
            for k, values in enumerate(history):
                label = "initial" if k == 0 else f"iteration {k}"
                frame[f"error {label}"] = P.natural_errors(values, reference, names)
        return frame
