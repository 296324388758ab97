"""The thermal fit: every calibration's table, with its full covariance, into one temperature model.

Calibration ``k`` at temperature ``T_k`` gives the parameter vector ``x_k`` with covariance ``C_k``
(the NLP's or the ILS's, correlations kept).  With ``t = T - T_ref`` the model
(:mod:`model.thermal`) is ``x_k = p_ref + a1 t_k + a2 t_k^2 + e_k``, ``e_k ~ N(0, C_k)``, the
calibrations independent of each other.  Generalised least squares over all of them at once::

    N = sum_k X_k^T C_k^-1 X_k,   theta = N^-1 sum_k X_k^T C_k^-1 x_k,   Sigma = N^-1

with ``X_k`` the rows of ``[I, t_k I, t_k^2 I]`` for the coefficients in the model (a parameter of
order 1 has no ``a2`` column).  The correlations of each calibration enter through ``C_k^-1``: a
parameter's coefficients borrow from the parameters it is correlated with, and the covariance of
the coefficients is joint.  For numbers of order one the fit runs in natural units about the mean
of the tables (scale factors in ppm of their value), and ``t`` in tens of degC; the result is
converted back exactly (the fit is linear).

Order by evidence (``auto``, three or more temperatures): every parameter starts quadratic; the
``a2`` whose ``|a2 / sigma|`` is below ``sqrt(2)`` (Akaike's criterion: a coefficient earns its place
when it lowers ``chi^2`` by more than 2) are set to zero and the fit repeated until none is dropped.
The covariances being known, the test needs no residual degrees of freedom.  The values are those
of the chosen orders; the covariance stays that of the all-quadratic fit: a curvature the data cannot
exclude remains in every sigma (``a2 = 0 +- sigma``), so that choosing an order after seeing the data
does not make the sigma too small (with only the chosen model's covariance, a weak curvature
dropped by the test biases the tables at other temperatures beyond their sigma).  ``--order 1`` or
``2`` forces the order and its own covariance.

Residuals: ``r_k = x_k - X_k theta`` has covariance ``C_k - X_k Sigma X_k^T``; a standardised
residual beyond 3 is reported (hysteresis, a bad run).  Per parameter ``chi^2_i = sum_k r_ki^2 /
C_k,ii`` over ``nu_i = m - order_i - 1`` degrees of freedom: where ``chi^2_i / nu_i > 1`` the
parameter's coefficients are widened by ``sqrt(chi^2_i / nu_i)`` (the Birge ratio, as the Particle
Data Group scales discrepant measurements), so that a scatter the calibrations' sigma does not
explain widens the model's sigma instead of being hidden.
"""

from __future__ import annotations

import dataclasses
import numpy as np

from ...core.errors import InputError
from ...model.parameters import ParameterSet
from ...model.registry import natural_size
from ...model.thermal import ThermalModel

#: ``a2`` stays when ``(a2 / sigma)^2`` exceeds this (Akaike: 2 per coefficient).
EVIDENCE_CHI2 = 2.0
#: A standardised residual beyond this is reported.
RESIDUAL_LIMIT = 3.0
#: Temperatures are fitted in units of this many degC (numbers of order one).
T_UNIT = 10.0
#: Calibrations closer in temperature than this (degC: a thermal chamber's stability and a sensor's resolution)
#: are of one setpoint: a slope between them would be the difference of two calibrations divided by nothing.
SETPOINT_RESOLUTION_C = 0.1


def setpoints(temps) -> list[list[float]]:
    """The temperatures grouped into setpoints: sorted, a new setpoint wherever the step to the next temperature
    exceeds :data:`SETPOINT_RESOLUTION_C`."""
    out: list[list[float]] = []
    for t in sorted(float(t) for t in temps):
        if out and t - out[-1][-1] <= SETPOINT_RESOLUTION_C:
            out[-1].append(t)
        else:
            out.append([t])
    return out


@dataclasses.dataclass
class Point:
    """One calibration of the unit: its temperature (degC), its table with covariance, a label, and where it
    comes from (``origin``: the SHA-256 of the table and of its recording, the date, the software)."""

    temperature_c: float
    params: ParameterSet
    label: str
    origin: dict | None = None


@dataclasses.dataclass
class ThermalFit:
    """The fitted model and what the fit tells about it.

    Attributes
    ----------
    model : ThermalModel
    points : list of Point
    residuals : ndarray (m, n)
        ``x_k - p(T_k)`` in natural units (scale factors ppm).
    standardized : ndarray (m, n)
        The residuals over their own sigma (``C_k - X_k Sigma X_k^T``); NaN where no residual degree of
        freedom checks the parameter (the curve passes through every calibration).
    chi2 : ndarray (n,)
        Per parameter, the sum of squared residuals over the calibrations' variances.
    dof : ndarray of int (n,)
    widened : ndarray (n,)
        The Birge factor applied to each parameter's coefficients (1 where none).
    a2_z : ndarray (n,)
        ``a2 / sigma`` of the quadratic fit that decided the order (nan when forced).
    warnings : list of str
    """

    model: ThermalModel
    points: list
    residuals: np.ndarray
    standardized: np.ndarray
    chi2: np.ndarray
    dof: np.ndarray
    widened: np.ndarray
    a2_z: np.ndarray
    warnings: list


def _scaling(points: list[Point]) -> tuple[np.ndarray, np.ndarray]:
    """The mean value of each parameter and the size of its natural unit (SI; scale factors relative)."""
    names = points[0].params.names
    mean = np.mean([p.params.values for p in points], axis=0)
    size = natural_size(names, mean)
    return mean, size


def _covariance_of(point: Point) -> np.ndarray:
    params = point.params
    if params.covariance is not None:
        return params.covariance
    return np.diag(params.sigma ** 2)


def _gls(ts: np.ndarray, ys: list, weights: list, orders: np.ndarray) -> tuple[np.ndarray, np.ndarray, list]:
    """GLS of the scaled problem: ``theta`` (3n, zeros where absent), ``Sigma`` (3n x 3n), and each ``X_k``."""
    n = len(orders)
    cols = np.concatenate([np.arange(2 * n), 2 * n + np.flatnonzero(orders == 2)])
    eye = np.eye(n)
    normal = np.zeros((len(cols), len(cols)))
    rhs = np.zeros(len(cols))
    designs = []
    for t, y, w in zip(ts, ys, weights):
        x = np.hstack([eye, t * eye, t * t * eye])[:, cols]
        designs.append(x)
        normal += x.T @ w @ x
        rhs += x.T @ w @ y
    try:
        cov_small = np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        raise InputError(None, "the thermal fit is singular: too few distinct temperatures for the order") from None
    theta = np.zeros(3 * n)
    theta[cols] = cov_small @ rhs
    cov = np.zeros((3 * n, 3 * n))
    cov[np.ix_(cols, cols)] = 0.5 * (cov_small + cov_small.T)
    full = [np.hstack([eye, t * eye, t * t * eye]) for t in ts]
    return theta, cov, full


def _weights(covs: list, labels: list) -> list:
    out = []
    for c, label in zip(covs, labels):
        try:
            factor = np.linalg.inv(np.linalg.cholesky(c))
            out.append(factor.T @ factor)
        except np.linalg.LinAlgError:
            raise InputError(label, "its covariance is not positive definite: it cannot weigh a thermal fit") from None
    return out


def fit_thermal(points: list[Point], order: str = "auto", reference_c: float = 25.0) -> ThermalFit:
    """Fit the temperature model of one unit (see the module docstring).

    Parameters
    ----------
    points : list of Point
        At least two calibrations, with sigma (better: full covariance), of the same parameters.
    order : {"auto", "1", "2"}
    reference_c : float
        ``T_ref``, degC.

    Raises
    ------
    InputError
        Too few temperatures for the order, tables without sigma, a covariance that is not positive definite.
    """
    temps = np.array([p.temperature_c for p in points], float)
    groups = setpoints(temps)
    distinct = len(groups)
    needed = 3 if order == "2" else 2
    if distinct < needed:
        close = [g for g in groups if len(g) > 1]
        what = (f" ({'; '.join(', '.join(f'{t:.10g}' for t in g) for g in close)} degC are within "
                f"{SETPOINT_RESOLUTION_C:g} degC of each other: one setpoint)" if close else "")
        raise InputError(None, f"{distinct} distinct temperature setpoint(s){what}: order {'2' if order == '2' else '1'} "
                         f"needs at least {needed} setpoints more than {SETPOINT_RESOLUTION_C:g} degC apart")
    for p in points:
        if p.params.sigma is None or np.any(~np.isfinite(p.params.sigma)):
            raise InputError(p.label, "no sigma for every parameter: a thermal fit weighs each calibration")
    n = len(points[0].params.names)
    mean, size = _scaling(points)
    ts = (temps - reference_c) / T_UNIT
    ys = [(p.params.values - mean) / size for p in points]
    covs = [_covariance_of(p) / np.outer(size, size) for p in points]
    weights = _weights(covs, [p.label for p in points])
    orders = np.full(n, 2 if (order == "2" or (order == "auto" and distinct >= 3)) else 1)
    a2_z = np.full(n, np.nan)
    theta, cov, designs = _gls(ts, ys, weights, orders)
    full_cov = cov
    if order == "auto" and distinct >= 3:
        a2_z = theta[2 * n:] / np.sqrt(np.clip(np.diag(cov)[2 * n:], 1e-300, None))
        while True:
            z = theta[2 * n:] / np.sqrt(np.clip(np.diag(cov)[2 * n:], 1e-300, None))
            drop = (orders == 2) & (z * z < EVIDENCE_CHI2)
            if not drop.any():
                break
            orders[drop] = 1
            theta, cov, designs = _gls(ts, ys, weights, orders)
    fitted = dict(theta=theta, cov=cov, designs=designs)
    # the reported covariance: the all-quadratic fit's under auto (the curvature the data cannot exclude stays)
    return _finish(points, temps, reference_c, fitted, full_cov, ys, covs, orders, a2_z, mean, size)


def _finish(points, temps, reference_c, fitted, cov, ys, covs, orders, a2_z, mean, size) -> ThermalFit:
    """Residuals (of the fitted orders), Birge widening of ``cov``, warnings, and the model back in SI per degC."""
    n, m = len(orders), len(points)
    theta, designs = fitted["theta"], fitted["designs"]
    residuals = np.array([y - x @ theta for y, x in zip(ys, designs)])
    dof = m - orders - 1
    standardized = _standardized(residuals, covs, designs, fitted["cov"], dof)
    chi2 = np.sum(residuals ** 2 / np.array([np.diag(c) for c in covs]), axis=0)
    ratio = np.where(dof > 0, chi2 / np.maximum(dof, 1), 1.0)
    widened = np.sqrt(np.maximum(ratio, 1.0))
    factor = np.tile(widened, 3)
    cov = cov * np.outer(factor, factor)
    # back to SI per degC: theta_j = size * scaled / T_UNIT^power, p_ref about the mean
    power = np.repeat([0, 1, 2], n)
    to_si = np.tile(size, 3) / T_UNIT ** power
    coef = (theta * to_si).reshape(3, n).T
    coef[:, 0] += mean
    model = ThermalModel(points[0].params.names, reference_c, coef, orders, cov * np.outer(to_si, to_si),
                         (float(temps.min()), float(temps.max())))
    warnings = _warnings(points, model, standardized, chi2, dof, len(np.unique(temps)))
    return ThermalFit(model, points, residuals, standardized, chi2, dof, widened, a2_z, warnings)


#: A residual whose variance is below this fraction of its calibration's own is no check (the curve passes
#: through the point: its residual is rounding, not evidence).
DETERMINED_FRACTION = 1e-9


def _standardized(residuals, covs, designs, cov, dof) -> np.ndarray:
    """Each residual over its own sigma (``C_k - X_k Sigma X_k^T``); NaN where nothing checks it: a parameter
    without residual degrees of freedom (two temperatures, or a quadratic through three) or a residual variance
    that vanishes against the calibration's own (the ratio would be rounding over rounding)."""
    own = np.array([np.diag(c) for c in covs])
    resid_var = np.array([np.diag(c - x @ cov @ x.T) for c, x in zip(covs, designs)])
    checked = (resid_var > DETERMINED_FRACTION * own) & (np.asarray(dof) > 0)[None, :]
    return np.where(checked, residuals / np.sqrt(np.where(checked, resid_var, 1.0)), np.nan)


def _warnings(points, model: ThermalModel, standardized, chi2, dof, distinct: int) -> list[str]:
    out = []
    names = model.names
    for k, i in zip(*np.nonzero(np.abs(standardized) > RESIDUAL_LIMIT)):
        out.append(f"{points[k].label} ({points[k].temperature_c:g} degC): {names[i]} is {standardized[k, i]:+.1f} "
                   "sigma off the fitted curve (hysteresis, a bad run, or a temperature model of higher order)")
    quad = int(np.sum(model.orders == 2))
    if quad and distinct == 3:
        out.append(f"{quad} parameter(s) of order 2 through only 3 temperatures: their curves pass through every point "
                   "and no residual checks them (4 or more setpoints give a check)")
    if distinct == 2:
        out.append("2 temperatures: straight lines through both, no residual checks them (3 or more setpoints give "
                   "a check, 4 or more a check of a quadratic)")
    bad = [names[i] for i in range(len(names)) if dof[i] > 0 and chi2[i] / dof[i] > 3.0]
    if bad:
        out.append(f"scatter beyond the calibrations' sigma (chi^2/dof > 3) for {', '.join(bad)}: their sigma "
                   "is widened by the Birge ratio")
    return out


