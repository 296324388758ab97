"""How good a schedule is: its predicted covariance (the one ``analyze`` computes) scored by a criterion.

Every schedule is scored by :func:`studies.prediction.predict_problem`, the covariance of the NLP's
linearisation whitened by the noise model (the Cramer-Rao bound of that model), so a design is judged
by exactly what ``analyze`` will say of it.  The parameters are in natural units (ug, ppm, arcsec,
deg/h); every criterion is a log ratio against the input schedule, so 0 is "as good as the input"
and -0.22 is "20 % smaller sigma":

``d``
    D-optimal: ``log det C / (2 n)`` (the geometric mean of the covariance's axes; unit-free);
``a``
    A-optimal: ``log mean(sigma_i^2 / sigma_ref,i^2) / 2`` (the trace of the covariance in units of the
    input schedule's variances: in bare natural units the gyro biases, 1e-5 deg/h, would not count);
``worst``
    ``log max(sigma_i / sigma_ref,i)``;
``navigation``
    the log of the static free-inertial position error after ``hours`` (:mod:`studies.budget`) with the
    predicted covariance; with a rotation ``scheme``, the log of the largest position error of the unit
    navigating under that scheme for ``hours`` (:mod:`.modulated`, the number ``modulate`` reports).

A parameter whose sigma exceeds ``cap`` times the input's adds ``PENALTY`` per unit of log excess:
a design should be no worse anywhere unless told (``--cap``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...calibrate.nlp.graph import variable_scale
from ...data.problem import Problem
from ...model.registry import N_PARAMS
from ..budget import problem_budget
from ..choices import DESIGN_CRITERIA
from ..prediction import Prediction, predict_problem

CRITERIA = DESIGN_CRITERIA
#: Weight of the log excess of a parameter's sigma over ``cap`` times the input's.
PENALTY = 10.0


def natural_covariance(pred: Prediction) -> np.ndarray:
    """The predicted covariance in natural units (the NLP's variables), from the SI one."""
    scale = variable_scale(pred.nominal.values, pred.nominal.names)
    return np.asarray(pred.nominal.covariance) / np.outer(scale, scale)


def navigation_error(problem: Problem, pred: Prediction, hours: float) -> float:
    """Horizontal position error (m, 1 sigma) of static free-inertial navigation after ``hours``."""
    n = N_PARAMS
    budget = problem_budget(problem, pred.nominal.values[:n], np.asarray(pred.nominal.covariance)[:n, :n],
                            hours=hours)
    return float(np.hypot(*budget.total[-1]))


@dataclasses.dataclass
class Score:
    """A schedule's prediction and its criterion value (log ratio against the input) with the penalty."""

    prediction: Prediction
    ratios: np.ndarray  # sigma / input sigma per parameter
    value: float  # criterion (log ratio)
    objective: float  # value + penalty

    @property
    def geometric_mean(self) -> float:
        """Geometric mean of the sigma ratios."""
        return float(np.exp(np.mean(np.log(self.ratios))))


class Criterion:
    """A criterion against a reference (the input schedule's prediction).

    Parameters
    ----------
    kind : str
        One of :data:`CRITERIA`.
    reference : Problem
        The input schedule (its prediction is the yardstick).
    model : str
        The parameter model (``"21"`` or ``"extended"``).
    cap : float
        Largest sigma ratio a parameter may have before the penalty applies.
    hours : float
        Navigation time of the ``navigation`` criterion.
    scheme : Scheme, optional
        With ``navigation``: the rotation scheme the unit runs in operation (else static strapdown).
    """

    def __init__(self, kind: str, reference: Problem, model: str = "21", cap: float = 1.1, hours: float = 1.0,
                 scheme=None):
        if kind not in CRITERIA:
            raise ValueError(f"criterion must be one of {', '.join(CRITERIA)}")
        if scheme is not None and kind != "navigation":
            raise ValueError("a rotation scheme goes with the navigation criterion")
        self.kind, self.model, self.cap, self.hours = kind, model, cap, hours
        self.modulated = None
        if scheme is not None:
            from .modulated import ModulatedNavigation  # the modulation model loads only when asked for
            self.modulated = ModulatedNavigation(reference, scheme, hours)
        self.reference = predict_problem(reference, model)
        self.ref_sigma = self.reference.sigma_natural
        self.ref_logdet = np.linalg.slogdet(natural_covariance(self.reference))[1]
        self.ref_navigation = self.navigation(reference, self.reference) if kind == "navigation" else 1.0
        self.evaluations = 0

    def navigation(self, problem: Problem, pred: Prediction) -> float:
        """The navigation error (m) of the ``navigation`` criterion for a prediction of ``problem``: static
        free-inertial after ``hours``, or the largest under the rotation scheme."""
        if self.modulated is None:
            return navigation_error(problem, pred, self.hours)
        return self.modulated(pred.nominal.values, np.asarray(pred.nominal.covariance))

    def score(self, problem: Problem) -> Score:
        """Predict a schedule and score it."""
        self.evaluations += 1
        return self.score_prediction(problem, predict_problem(problem, self.model))

    def score_prediction(self, problem: Problem, pred: Prediction) -> Score:
        """Score a prediction of ``problem``."""
        ratios = pred.sigma_natural / self.ref_sigma
        if self.kind == "d":
            logdet = np.linalg.slogdet(natural_covariance(pred))[1]
            value = (logdet - self.ref_logdet) / (2.0 * len(ratios))
        elif self.kind == "a":
            value = 0.5 * np.log(np.mean(ratios**2))
        elif self.kind == "worst":
            value = np.log(ratios.max())
        else:
            value = np.log(self.navigation(problem, pred) / self.ref_navigation)
        excess = np.maximum(np.log(ratios) - np.log(self.cap), 0.0).sum()
        value = float(value) if np.isfinite(value) else np.inf
        return Score(pred, ratios, value, value + PENALTY * float(excess))
