"""A temperature model of the parameters: one polynomial per parameter, with the joint covariance.

Every parameter ``p`` of the output model (eq. 1 of Kang et al. 2013: biases, scale factors,
misalignments, and any extra group) moves with the unit's temperature ``T`` (degC) as::

    p(T) = p_ref + a1 (T - T_ref) + a2 (T - T_ref)^2

in the table's SI unit (``a1`` per degC, ``a2`` per degC^2; ``a2 = 0`` for a parameter of order 1).
The coefficients of all parameters are one vector ``theta = [p_ref (n), a1 (n), a2 (n)]`` with one
covariance (3n x 3n): a parameter table at any temperature is ``G(T) theta`` with covariance
``G Sigma G^T``, ``G(T) = [I, (T - T_ref) I, (T - T_ref)^2 I]``, so the correlations between the
parameters (and between the coefficients) are carried to every temperature.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .parameters import ParameterSet

#: The coefficients per parameter, in the order of ``ThermalModel.coefficients``' columns.
COEFFICIENTS = ("p_ref", "a1", "a2")


@dataclasses.dataclass
class ThermalModel:
    """Polynomials in temperature of a unit's parameters.

    Attributes
    ----------
    names : tuple of str
        The parameters, in table order.
    reference_c : float
        ``T_ref``, degC.
    coefficients : ndarray (n, 3)
        ``p_ref`` (SI), ``a1`` (SI/degC), ``a2`` (SI/degC^2) per parameter.
    orders : ndarray of int (n,)
        1 or 2 per parameter (``a2`` is 0 where 1).
    covariance : ndarray (3n, 3n) or None
        Of ``theta = coefficients.T.ravel()`` (all ``p_ref``, then all ``a1``, then all ``a2``); rows and
        columns of the ``a2`` of an order-1 parameter are zero.
    range_c : (float, float)
        The lowest and highest calibrated temperature, degC (outside it a table is an extrapolation).
    """

    names: tuple[str, ...]
    reference_c: float
    coefficients: np.ndarray
    orders: np.ndarray
    covariance: np.ndarray | None = None
    range_c: tuple[float, float] = (float("nan"), float("nan"))

    def __post_init__(self):
        self.names = tuple(self.names)
        n = len(self.names)
        self.coefficients = np.asarray(self.coefficients, dtype=float).reshape(n, 3)
        self.orders = np.asarray(self.orders, dtype=int).reshape(n)
        if self.covariance is not None:
            self.covariance = np.asarray(self.covariance, dtype=float).reshape(3 * n, 3 * n)

    @property
    def sigma(self) -> np.ndarray:
        """1-sigma of each coefficient (n, 3), SI; nan without a covariance."""
        n = len(self.names)
        if self.covariance is None:
            return np.full((n, 3), np.nan)
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None)).reshape(3, n).T

    def design(self, temperature_c: float) -> np.ndarray:
        """``G(T)`` (n, 3n): the parameters at ``T`` are ``G theta``."""
        dt = float(temperature_c) - self.reference_c
        eye = np.eye(len(self.names))
        return np.hstack([eye, dt * eye, dt * dt * eye])

    def values_at(self, temperature_c) -> np.ndarray:
        """The parameter values (SI) at each temperature: shape ``(n,)`` for a number, ``(len, n)`` for an array."""
        t = np.asarray(temperature_c, dtype=float)
        dt = (t - self.reference_c)[..., None]
        c = self.coefficients
        return c[:, 0] + dt * c[:, 1] + dt * dt * c[:, 2]

    def at(self, temperature_c: float) -> ParameterSet:
        """The parameter table at ``temperature_c`` with its covariance from the model's (``G Sigma G^T``)."""
        values = self.values_at(float(temperature_c))
        cov = None
        if self.covariance is not None:
            g = self.design(temperature_c)
            cov = g @ self.covariance @ g.T
            cov = 0.5 * (cov + cov.T)
        return ParameterSet(values, covariance=cov, names=self.names)

    def clamped(self, temperature_c):
        """``temperature_c`` (a number or an array) held within the calibrated range: the temperature at which the
        firmware header (:mod:`report.cheader_thermal`) and ``apply --thermal`` evaluate the model."""
        low, high = self.range_c
        if not (np.isfinite(low) and np.isfinite(high)):
            return temperature_c
        out = np.clip(temperature_c, low, high)
        return float(out) if np.ndim(out) == 0 else out

    def extrapolates(self, temperature_c: float) -> bool:
        """Whether ``temperature_c`` lies outside the calibrated range."""
        low, high = self.range_c
        return bool(np.isfinite(low) and (temperature_c < low or temperature_c > high))
