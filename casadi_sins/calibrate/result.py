"""What a calibration returns: the parameter table with its covariance, and everything to trust it.

:class:`CalibrationResult` is in the manner of ``scipy.optimize.OptimizeResult``: ``success``,
``status``, ``message`` and ``nit`` first, then documented fields, a readable ``repr`` and a
``summary()``.  A calibration that cannot give a trustworthy table raises :class:`CalibrationError`
instead of returning.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from ..model.noise import SensorNoise
from ..model.parameters import ParameterSet, natural_errors
from ..noise.motion import SegmentMotion
from ..noise.observations import ObservationTable
from ..noise.raw import RawNoise
from ..noise.translation import LinearMotion
from ..noise.wander import SensorWander


class CalibrationError(RuntimeError):
    """A calibration that cannot give a trustworthy parameter table (no convergence, rank deficiency)."""


@dataclasses.dataclass
class Check:
    """One consistency check of a fit against its noise model.

    ``passed`` is ``low <= value <= limit``; ``low`` is 0 for one-sided checks.  A check of a least
    amount (``at_least``: the shortest rest) passes when ``value >= limit``: its ``limit`` is that
    least amount and ``low`` is not used.  :attr:`accepted` states the limit as people read it, the
    report's limit column.
    """

    name: str
    value: float
    limit: float
    passed: bool
    detail: str
    low: float = 0.0
    at_least: bool = False

    @property
    def accepted(self) -> str:
        """The accepted values as text: ``>= 0.43``, ``<= 1.22``, ``0.777 to 1.22``, ``|x| <= 0.152``."""
        if self.at_least:
            return f">= {self.limit:.3g}"
        if self.low == 0.0:
            return f"<= {self.limit:.3g}"
        if self.low == -self.limit:
            return f"|x| <= {self.limit:.3g}"
        return f"{self.low:.3g} to {self.limit:.3g}"

    def as_dict(self) -> dict:
        """Plain data, for the report (with :attr:`accepted`)."""
        return {**dataclasses.asdict(self), "accepted": self.accepted}


@dataclasses.dataclass
class NoiseReport:
    """The noise model of a calibration: in use, measured in the raw data, implied by the fit, where
    each term came from (``"datasheet"``, ``"raw data"``, ``"fit"``, ``"static data (restricted
    likelihood)"``, ``"not modelled"``), and the bias instability the static data show for the sensors
    without a datasheet value (sensor -> :class:`noise.wander.SensorWander`)."""

    model: SensorNoise
    raw: RawNoise | None = None
    fitted: SensorNoise | None = None
    sources: dict[str, str] = dataclasses.field(default_factory=dict)
    bias_wander: dict[str, SensorWander] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class NlpDetails:
    """What only the NLP solver has: Ipopt's run, the post-solve steps, the model decisions."""

    ipopt_status: str
    ipopt_iterations: int
    gls_steps: list[float]
    rotation_steps_used: bool
    rotation_step_ratio: float
    start_offsets_arcsec: dict[int, np.ndarray]
    start_attitudes: dict[int, np.ndarray]
    model: tuple[str, ...]
    model_selection: dict | None
    observe_s: float
    static_step_s: float
    graph_build_s: float
    observations: ObservationTable
    whitened_residuals: np.ndarray
    white_noise_per_sample: dict[str, float]
    #: Extra groups ``extended``/``auto`` left out because the schedule cannot separate them from one of the 21:
    #: ``{group: {"parameter", "correlation", "note"}}``.
    left_out: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class IlsDetails:
    """What only the reference solver has: its equations and per-iteration corrections."""

    equations: int
    labels: list[str]
    corrections_natural: list[np.ndarray]
    paper_sigma_natural: np.ndarray | None = None  # the paper's: formal sigma of the last solve, first weights
    free_levels: dict = dataclasses.field(default_factory=dict)  # white terms sized by the equations (SI)
    curvature: float = 0.0  # largest share of a variance from second order


@dataclasses.dataclass(repr=False)
class CalibrationResult:
    """Outcome of a calibration.

    Attributes
    ----------
    parameters : ParameterSet
        Estimate with its covariance (SI).
    solver : str
        ``"nlp"`` (CasADi/Ipopt) or ``"ils"`` (the paper's iterative least squares).
    success : bool
        The solver converged (a failure raises :class:`CalibrationError` instead).
    status : int
        0: converged, no warning; 1: converged with warnings (see ``warnings``).
    message : str
    nit : int
        Iterations (Ipopt's, or the ILS's).
    initial : ParameterSet
        Starting values (the paper's rough initial values unless given).
    history : list of ndarray
        Parameter vector after each iteration (index 0: initial).
    residual_rms : float
        RMS of the whitened residuals (1 for a noise model that fits).
    wall_time : float
        Seconds from recording to parameter table.
    sigma_meaning : str
        What ``sigma`` in the table stands for.
    warnings : list of str
        Doubts about the table, for the user and the report.
    checks : list of Check
    variance_factor : float
        Factor applied to the covariance when the residuals exceed the noise model (1 otherwise).
    noise : NoiseReport
    base_motion : list of SegmentMotion
    linear_motion : LinearMotion or None
        The base's linear motion (a deck's heave and surge), when it was looked for.
    distrust : list of str
        Why the calibration's own checks do not trust the table (:mod:`calibrate.trust`); empty when they do.
    timings : dict
        Seconds per phase.
    nlp, ils : NlpDetails or IlsDetails or None
        Solver-specific details.
    notes : list of str
        What the report states without doubting the table (a term the data hint at that would change no
        value beyond its noise).
    """

    parameters: ParameterSet
    solver: str
    success: bool
    status: int
    message: str
    nit: int
    initial: ParameterSet
    history: list[np.ndarray]
    residual_rms: float
    wall_time: float
    sigma_meaning: str
    warnings: list[str]
    checks: list[Check]
    variance_factor: float
    noise: NoiseReport
    base_motion: list[SegmentMotion] = dataclasses.field(default_factory=list)
    timings: dict[str, float] = dataclasses.field(default_factory=dict)
    nlp: NlpDetails | None = None
    ils: IlsDetails | None = None
    notes: list[str] = dataclasses.field(default_factory=list)
    linear_motion: LinearMotion | None = None
    distrust: list[str] = dataclasses.field(default_factory=list)

    @property
    def x(self) -> np.ndarray:
        """The parameter values (SI), as ``OptimizeResult.x``."""
        return self.parameters.values

    @property
    def start_attitudes(self) -> dict[int, np.ndarray] | None:
        """The NLP's estimated start attitude of each group (``None`` for the ILS: it aligns)."""
        return self.nlp.start_attitudes if self.nlp else None

    def __repr__(self) -> str:
        sigma = self.parameters.natural_sigma()
        lines = [f"CalibrationResult(solver={self.solver!r}, success={self.success}, status={self.status}, "
                 f"nit={self.nit}, wall_time={self.wall_time:.2f} s)",
                 f"  message: {self.message}"]
        for name, value, s, unit in zip(self.parameters.names, self.parameters.values, sigma,
                                        self.parameters.natural_units):
            lines.append(f"  {name:<22} {value: .9e}  sigma {s:.3g} {unit}")
        return "\n".join(lines)

    def summary(self) -> str:
        """A few lines: the outcome, the noise sources, the warnings."""
        lines = [f"{self.solver}: {self.message} ({self.nit} iterations, {self.wall_time:.2f} s); "
                 f"whitened residual rms {self.residual_rms:.3g}, variance factor {self.variance_factor:.3g}"]
        if self.noise.sources:
            lines.append("noise: " + ", ".join(f"{k} {v}" if v == "not modelled" else f"{k} from {v}"
                                               for k, v in self.noise.sources.items()))
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def history_frame(self, truth: ParameterSet | None = None) -> pd.DataFrame:
        """Parameters x iterations, shaped like the paper's Table 2 (values; errors in natural units with truth)."""
        names = self.parameters.names
        frame = pd.DataFrame({"parameter": names, "unit": self.parameters.units})
        history = [np.asarray(v)[: len(names)] for v in self.history]
        for k, values in enumerate(history):
            frame["initial" if k == 0 else f"iteration {k}"] = values
        if truth is not None:
            reference = truth.aligned(names)
            frame["truth"] = reference
            frame["error unit"] = self.parameters.natural_units
            for k, values in enumerate(history):
                label = "initial" if k == 0 else f"iteration {k}"
                frame[f"error {label}"] = natural_errors(values, reference, names)
        return frame


def outcome(warnings: list[str], iterations: int) -> tuple[int, str]:
    """``(status, message)`` of a converged calibration."""
    if warnings:
        return 1, f"converged in {iterations} iterations with {len(warnings)} warning(s)"
    return 0, f"converged in {iterations} iterations"
