"""A set of parameter values with its uncertainty, and errors against a truth in natural units.

Values are SI, in the order of their names: the paper's 21 (:data:`model.registry.NAMES`) first,
then any extra groups.  Scale-factor errors are relative (``S_hat/S - 1``, the paper's ``t_ii``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from .registry import (NAMES, N_PARAMS, error_scale, group_of, groups_in, model_names, natural_scale_of,
                       natural_unit_of, relative_covariance, relative_mask, unit_of)


def parameter_errors(estimate, truth, names=NAMES) -> np.ndarray:
    """Errors of an estimate, SI with scale factors relative, ordered like ``names``.

    Biases, misalignments and extra terms: ``estimate - truth``; scale factors ``estimate/truth - 1``
    (the ``t_ii`` of the paper).  Divide by :func:`registry.natural_scale_of` for natural units.
    """
    estimate, truth = np.asarray(estimate, float), np.asarray(truth, float)
    err = estimate - truth
    mask = relative_mask(names)
    err[mask] = estimate[mask] / truth[mask] - 1.0
    return err


def natural_errors(estimate, truth, names=None) -> np.ndarray:
    """Errors of an estimate in natural units (ug, ppm, arcsec, deg/h; mm, ms, ug/g^2 for the extras).

    ``estimate`` and ``truth`` may be arrays (ordered like ``names``, default the 21) or
    :class:`ParameterSet` objects: then the estimate's names, with the truth's value or the group's
    prior (0) where the truth lacks a name (a truth file of the 21 against an extended estimate).
    """
    if isinstance(estimate, ParameterSet):
        names = estimate.names
        truth = truth.aligned(names) if isinstance(truth, ParameterSet) else truth
        estimate = estimate.values
    elif isinstance(truth, ParameterSet):
        truth = truth.aligned(names or NAMES)
    names = names or NAMES
    return parameter_errors(estimate, truth, names) / natural_scale_of(names)


def truth_errors(estimate: "ParameterSet", truth: "ParameterSet") -> np.ndarray:
    """:func:`natural_errors` of an estimate against a truth file, ``nan`` where the truth does not give the
    parameter (a truth file of the 21 against an extended estimate: the extra terms' errors are unknown, not
    their distance from the prior)."""
    known = np.array([n in truth.names for n in estimate.names])
    return np.where(known, natural_errors(estimate, truth), np.nan)


def joint_chi_square(estimate: "ParameterSet", truth: "ParameterSet") -> float:
    """The errors of an estimate against a truth, weighed by the estimate's own covariance.

    ``e^T C^-1 e`` with ``e`` the errors of :func:`parameter_errors` (scale factors relative) and ``C``
    the estimate's :meth:`ParameterSet.relative_covariance`.  When the covariance is honest the value
    follows a chi-square distribution with as many degrees of freedom as parameters (21: between 6.4
    and 46.8 in 99.8 % of recordings).  ``nan`` without a covariance or when it is singular.
    """
    cov = estimate.relative_covariance()
    if cov is None:
        return float("nan")
    err = parameter_errors(estimate.values, truth.aligned(estimate.names), estimate.names)
    try:
        factor = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        return float("nan")
    white = np.linalg.solve(factor, err)
    return float(white @ white)


@dataclasses.dataclass
class ParameterSet:
    """Values of the parameters with optional uncertainty.

    Attributes
    ----------
    values : ndarray (n,)
        SI, in the order of ``names``.
    sigma : ndarray (n,) or None
        1-sigma uncertainty of each value, SI.
    covariance : ndarray (n, n) or None
        Full covariance in SI; when given, ``sigma`` is its diagonal root.
    names : tuple of str
        The paper's 21 (:data:`registry.NAMES`), or :func:`registry.model_names` of some extra groups.
    """

    values: np.ndarray
    sigma: np.ndarray | None = None
    covariance: np.ndarray | None = None
    names: tuple[str, ...] = NAMES

    def __post_init__(self):
        self.names = tuple(self.names)
        n = len(self.names)
        self.values = np.asarray(self.values, dtype=float).reshape(n)
        if self.covariance is not None:
            self.covariance = np.asarray(self.covariance, dtype=float).reshape(n, n)
            if self.sigma is None:
                self.sigma = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        if self.sigma is not None:
            self.sigma = np.asarray(self.sigma, dtype=float).reshape(n)

    def __getitem__(self, name: str) -> float:
        return float(self.values[self.names.index(name)])

    @property
    def units(self) -> tuple[str, ...]:
        """SI unit of each value."""
        return tuple(unit_of(n) for n in self.names)

    @property
    def natural_units(self) -> tuple[str, ...]:
        """Natural unit of each error."""
        return tuple(natural_unit_of(n) for n in self.names)

    def natural_sigma(self) -> np.ndarray:
        """1-sigma of each parameter in the natural unit of its error (scale factors relative, ppm)."""
        if self.sigma is None:
            return np.full(len(self.names), np.nan)
        return self.sigma / natural_scale_of(self.names) / error_scale(self.names, self.values)

    def relative_covariance(self) -> np.ndarray | None:
        """Covariance of the errors in SI with scale factors relative (the units of :func:`parameter_errors`)."""
        if self.covariance is None:
            return None
        return relative_covariance(self.names, self.values, self.covariance)

    @property
    def core(self) -> np.ndarray:
        """The 21 parameters of the paper's model."""
        return self.values[:N_PARAMS]

    @property
    def extras(self) -> tuple[str, ...]:
        """The extra groups present."""
        return groups_in(self.names)

    def aligned(self, names) -> np.ndarray:
        """Values in the order of ``names``; names not present take their group's prior."""
        lookup = dict(zip(self.names, self.values))
        return np.array([lookup[n] if n in lookup else group_of(n).prior for n in names])

    def as_dict(self) -> dict[str, float]:
        """``{name: SI value}``."""
        return dict(zip(self.names, (float(v) for v in self.values)))

    @classmethod
    def from_dict(cls, values: dict[str, float]) -> "ParameterSet":
        """From ``{name: SI value}``: all 21, and every name of each extra group that appears.

        Raises
        ------
        ValueError
            Naming the missing parameters.
        """
        names = model_names(groups_in(values))
        missing = [n for n in names if n not in values]
        if missing:
            raise ValueError(f"missing parameters: {', '.join(missing)}")
        return cls(np.array([values[n] for n in names]), names=names)

    def to_frame(self, truth: "ParameterSet | None" = None) -> pd.DataFrame:
        """The parameter table as a DataFrame (``truth`` adds truth and natural-unit error)."""
        names = self.names
        natural = [natural_unit_of(n) for n in names]
        frame = pd.DataFrame({"parameter": names, "unit": [unit_of(n) for n in names], "value": self.values,
                              "sigma": self.sigma if self.sigma is not None else np.nan})
        if self.sigma is not None:
            frame["sigma_natural"] = self.natural_sigma()
            frame["natural_unit"] = natural
        if truth is not None:
            frame["truth"] = [truth[n] if n in truth.names else np.nan for n in names]
            frame["error_natural"] = truth_errors(self, truth)
            frame["natural_unit"] = natural
        return frame


#: Correlations above this (in absolute value) mean two parameters are not separated by the schedule.
CORRELATION_LIMIT = 0.99


@dataclasses.dataclass
class Separation:
    """How well a covariance separates its parameters.

    Attributes
    ----------
    weak : list of (name, sigma, unit)
        Parameters whose natural-unit sigma exceeds their group's ``weak_level``.
    correlated : list of (name, name, correlation)
        Pairs correlated beyond :data:`CORRELATION_LIMIT`, strongest first.
    condition : float
        Condition number of the correlation matrix.
    """

    weak: list
    correlated: list
    condition: float

    @property
    def separated(self) -> bool:
        """No weak parameter and no pair correlated beyond the limit."""
        return not self.weak and not self.correlated


def offset_free_covariance(params: ParameterSet) -> np.ndarray:
    """The covariance with each of the 21's biases taken at its axis's scale factor, ``B_i - (B_i / S_i) S_i``
    linearised at the values: raw counts with an offset make ``B = S x offset / dt``, so that the bias's own
    uncertainty is the scale factor's times the offset, correlated with it to 0.9999; at its scale factor it is
    what the data leave of it.  For pulses without an offset the change is below round-off of the sigmas."""
    jac = np.eye(len(params.names))
    for sensor in ("accel", "gyro"):
        for axis in "xyz":
            bias, scale = f"{sensor}_bias_{axis}", f"{sensor}_scale_{axis}"
            if bias in params.names and scale in params.names and params[scale] != 0.0:
                jac[params.names.index(bias), params.names.index(scale)] = -params[bias] / params[scale]
    return jac @ params.covariance @ jac.T


def separation(params: ParameterSet, levels: dict[str, float] | None = None) -> Separation:
    """Weak parameters and inseparable pairs of an estimate's covariance (see :class:`Separation`), the biases at
    their scale factors (:func:`offset_free_covariance`); ``levels`` replaces the groups' ``weak_level`` of the
    names it gives (natural units: thresholds by the unit's grade)."""
    if params.covariance is None:
        return Separation([], [], float("nan"))
    covariance = offset_free_covariance(params)
    sigma = ParameterSet(params.values, covariance=covariance, names=params.names).natural_sigma()
    levels = levels or {}
    weak = [(n, float(s), natural_unit_of(n)) for n, s in zip(params.names, sigma)
            if s > levels.get(n, group_of(n).weak_level)]
    sd = np.sqrt(np.clip(np.diag(covariance), 1e-300, None))
    corr = covariance / np.outer(sd, sd)
    n = len(params.names)
    pairs = sorted(((abs(corr[i, j]), i, j) for i in range(n) for j in range(i + 1, n)
                    if abs(corr[i, j]) > CORRELATION_LIMIT), reverse=True)
    correlated = [(params.names[i], params.names[j], float(corr[i, j])) for _, i, j in pairs]
    eig = np.linalg.eigvalsh(0.5 * (corr + corr.T))
    condition = float(eig[-1] / max(eig[0], 1e-300))
    return Separation(weak, correlated, condition)
