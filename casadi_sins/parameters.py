"""The 21 parameters of the sensor output model (Kang et al. 2013, eq. 1).

Per sample interval ``dt``, with ``dtheta`` the true angular increment and
``dv`` the true specific-force increment in the body frame::

    dN_g = diag(S_g)^-1 (K_g dtheta + B_g dt)          (eq. 1)
    dN_a = diag(S_a)^-1 (K_a dv     + B_a dt)

``K_g`` is unit-diagonal with six off-diagonal misalignments, ``K_a`` is
unit-lower-triangular with three.  Compensation inverts the model exactly
(``K^-1``, never ``I - k``).

The parameter vector is in SI units and in the order of :data:`NAMES` (the
order of the parameter table in the recording-format spec).  The output model
and its inverse are written once, as CasADi expressions, so that the
simulator, the navigation and the symbolic estimator share them.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import casadi as ca
import numpy as np
import pandas as pd

from .units import ARCSEC, DEG_PER_H, PPM, TO_SI, UG

NAMES = (
    "accel_bias_x", "accel_bias_y", "accel_bias_z",
    "accel_scale_x", "accel_scale_y", "accel_scale_z",
    "accel_misalign_yx", "accel_misalign_zx", "accel_misalign_zy",
    "gyro_bias_x", "gyro_bias_y", "gyro_bias_z",
    "gyro_scale_x", "gyro_scale_y", "gyro_scale_z",
    "gyro_misalign_xy", "gyro_misalign_xz", "gyro_misalign_yx",
    "gyro_misalign_yz", "gyro_misalign_zx", "gyro_misalign_zy",
)  # fmt: skip
N_PARAMS = len(NAMES)
INDEX = {name: i for i, name in enumerate(NAMES)}

ACCEL_BIAS = slice(0, 3)
ACCEL_SCALE = slice(3, 6)
ACCEL_MISALIGN = slice(6, 9)
GYRO_BIAS = slice(9, 12)
GYRO_SCALE = slice(12, 15)
GYRO_MISALIGN = slice(15, 21)

#: Parameter groups, for reports: (label, slice, natural unit of the error).
GROUPS = (
    ("accel bias", ACCEL_BIAS, "ug"),
    ("accel scale", ACCEL_SCALE, "ppm"),
    ("accel misalignment", ACCEL_MISALIGN, "arcsec"),
    ("gyro bias", GYRO_BIAS, "deg/h"),
    ("gyro scale", GYRO_SCALE, "ppm"),
    ("gyro misalignment", GYRO_MISALIGN, "arcsec"),
)

ACCEL_MISALIGN_ENTRIES = ((1, 0), (2, 0), (2, 1))  # (row, column) of K_a
GYRO_MISALIGN_ENTRIES = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))


def _unit(name: str) -> str:
    if "_bias_" in name:
        return "m/s^2" if name.startswith("accel") else "rad/s"
    if "_scale_" in name:
        return "m/s/pulse" if name.startswith("accel") else "rad/pulse"
    return "rad"


#: SI unit of each parameter, as written in the parameter table.
UNITS = tuple(_unit(n) for n in NAMES)


def _natural(name: str) -> tuple[str, float]:
    if name.startswith("accel_bias"):
        return "ug", UG
    if name.startswith("gyro_bias"):
        return "deg/h", DEG_PER_H
    if "_scale_" in name:
        return "ppm", PPM
    return "arcsec", ARCSEC


#: Natural unit of the *error* of each parameter and its size in SI
#: (for scale factors a relative error: ppm of the value).
NATURAL_UNITS = tuple(_natural(n)[0] for n in NAMES)
NATURAL_SCALE = np.array([_natural(n)[1] for n in NAMES])
SCALE_MASK = np.array(["_scale_" in n for n in NAMES])


# --------------------------------------------------------------------------- model
def sensor_matrices(p):
    """``(K_a, S_a, B_a, K_g, S_g, B_g)`` of a parameter vector (CasADi or NumPy, SI).

    ``S`` and ``B`` are 3-vectors, ``K`` the 3x3 misalignment matrices of eq. 1
    (unit diagonal; ``K_a`` lower triangular; row = sensor axis).
    """
    if not isinstance(p, (ca.SX, ca.MX, ca.DM)):
        p = ca.DM(np.asarray(p, dtype=float).reshape(N_PARAMS))

    def misalignment(entries, offset):
        rows = [[1 if i == j else 0 for j in range(3)] for i in range(3)]
        for n, (i, j) in enumerate(entries):
            rows[i][j] = p[offset + n]
        return ca.vertcat(*[ca.horzcat(*row) for row in rows])

    k_a = misalignment(ACCEL_MISALIGN_ENTRIES, ACCEL_MISALIGN.start)
    k_g = misalignment(GYRO_MISALIGN_ENTRIES, GYRO_MISALIGN.start)
    return k_a, p[ACCEL_SCALE], p[ACCEL_BIAS], k_g, p[GYRO_SCALE], p[GYRO_BIAS]


def output_model_expr(dtheta, dv, p, dt):
    """Raw pulses ``(dN_g, dN_a)`` from true increments (eq. 1); CasADi expressions.

    ``dtheta``, ``dv`` may be 3 x n matrices of n intervals with ``dt`` a 1 x n row.
    """
    k_a, s_a, b_a, k_g, s_g, b_g = sensor_matrices(p)
    dn_g = ca.diag(1 / s_g) @ (k_g @ dtheta + b_g @ dt)
    dn_a = ca.diag(1 / s_a) @ (k_a @ dv + b_a @ dt)
    return dn_g, dn_a


def compensate_expr(dn_g, dn_a, p, dt):
    """Increments ``(dtheta, dv)`` from raw pulses: the exact inverse of eq. 1.

    ``dn_g``, ``dn_a`` may be 3 x n matrices of pulse sums over n intervals with ``dt`` a 1 x n row
    (the model is linear, so summed pulses compensate exactly to summed increments).
    """
    k_a, s_a, b_a, k_g, s_g, b_g = sensor_matrices(p)
    dtheta = ca.solve(k_g, ca.diag(s_g) @ dn_g - b_g @ dt)
    dv = ca.solve(k_a, ca.diag(s_a) @ dn_a - b_a @ dt)
    return dtheta, dv


@functools.lru_cache(maxsize=None)
def output_model_function() -> ca.Function:
    """CasADi ``Function`` (dtheta[3], dv[3], p[21], dt) -> (dN_g[3], dN_a[3])."""
    dth, dv, p, dt = ca.SX.sym("dtheta", 3), ca.SX.sym("dv", 3), ca.SX.sym("p", N_PARAMS), ca.SX.sym("dt")
    return ca.Function("output_model", [dth, dv, p, dt], list(output_model_expr(dth, dv, p, dt)),
                       ["dtheta", "dv", "p", "dt"], ["dN_g", "dN_a"])


@functools.lru_cache(maxsize=None)
def compensate_function() -> ca.Function:
    """CasADi ``Function`` (dN_g[3], dN_a[3], p[21], dt) -> (dtheta[3], dv[3])."""
    dng, dna, p, dt = ca.SX.sym("dN_g", 3), ca.SX.sym("dN_a", 3), ca.SX.sym("p", N_PARAMS), ca.SX.sym("dt")
    return ca.Function("compensate", [dng, dna, p, dt], list(compensate_expr(dng, dna, p, dt)),
                       ["dN_g", "dN_a", "p", "dt"], ["dtheta", "dv"])


@functools.lru_cache(maxsize=None)
def _affine_function(which: str) -> ca.Function:
    """``(p, dt) -> (M_g, c_g, M_a, c_a)``: the model is affine in its input, ``y = M x + c``."""
    fun = output_model_function() if which == "output" else compensate_function()
    a, b, p, dt = ca.SX.sym("a", 3), ca.SX.sym("b", 3), ca.SX.sym("p", N_PARAMS), ca.SX.sym("dt")
    out_a, out_b = fun(a, b, p, dt)
    at_zero = ca.substitute([out_a, out_b], [a, b], [ca.DM.zeros(3), ca.DM.zeros(3)])
    return ca.Function(f"{which}_affine", [p, dt],
                       [ca.jacobian(out_a, a), at_zero[0], ca.jacobian(out_b, b), at_zero[1]])


def _apply_rows(which: str, a: np.ndarray, b: np.ndarray, p, dt: float):
    m_a, c_a, m_b, c_b = (np.asarray(x) for x in _affine_function(which)(np.asarray(p, dtype=float), dt))
    a = np.atleast_2d(np.asarray(a, dtype=float))
    b = np.atleast_2d(np.asarray(b, dtype=float))
    return a @ m_a.T + c_a.T, b @ m_b.T + c_b.T


def output_model(dtheta: np.ndarray, dv: np.ndarray, p, dt: float):
    """Raw pulses from true increments, rows of samples: arrays (N, 3) -> (dN_g, dN_a) (N, 3)."""
    return _apply_rows("output", dtheta, dv, p, dt)


def compensate(dn_g: np.ndarray, dn_a: np.ndarray, p, dt: float):
    """Compensated increments from raw pulses: arrays (N, 3) -> (dtheta, dv) (N, 3).

    Evaluates :func:`compensate_expr` as the affine map it is (its Jacobian and
    offset, from CasADi) and applies that to all samples at once.
    """
    return _apply_rows("compensate", dn_g, dn_a, p, dt)


def apply_error_estimate(p: np.ndarray, errors: np.ndarray) -> np.ndarray:
    """Correct parameters with estimated errors (eqs. 22-25).

    ``errors`` is ordered like :data:`NAMES`: for biases ``eps``/``Delta``
    (true minus estimated, SI), for scale factors ``t_ii = S_hat/S - 1``,
    for misalignments ``t_ij = k - k_hat``.  Returns the corrected vector::

        k_ij <- k_hat_ij + t_ij,   S_i <- S_hat_i / (1 + t_ii),   B <- B_hat + eps
    """
    p = np.asarray(p, dtype=float).copy()
    errors = np.asarray(errors, dtype=float)
    p[~SCALE_MASK] += errors[~SCALE_MASK]
    p[SCALE_MASK] /= 1.0 + errors[SCALE_MASK]
    return p


def parameter_errors(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Errors of an estimate in SI-like form (scale factors relative), ordered like :data:`NAMES`.

    Biases and misalignments: ``estimate - truth``; scale factors
    ``estimate/truth - 1`` (the ``t_ii`` of the paper).  Divide by
    :data:`NATURAL_SCALE` for natural units.
    """
    estimate, truth = np.asarray(estimate, float), np.asarray(truth, float)
    err = estimate - truth
    err[SCALE_MASK] = estimate[SCALE_MASK] / truth[SCALE_MASK] - 1.0
    return err


def natural_errors(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Errors of an estimate in natural units (ug, ppm, arcsec, deg/h)."""
    return parameter_errors(estimate, truth) / NATURAL_SCALE


# --------------------------------------------------------------------------- table
class ParameterTableError(ValueError):
    """A parameter table that cannot be read."""


@dataclasses.dataclass
class ParameterSet:
    """Values of the 21 parameters (SI, order of :data:`NAMES`) with optional uncertainty.

    Attributes
    ----------
    values : ndarray (21,)
    sigma : ndarray (21,) or None
        1-sigma uncertainty of each value, SI.
    covariance : ndarray (21, 21) or None
        Full covariance in SI; when given, ``sigma`` is its diagonal root.
    """

    values: np.ndarray
    sigma: np.ndarray | None = None
    covariance: np.ndarray | None = None

    def __post_init__(self):
        self.values = np.asarray(self.values, dtype=float).reshape(N_PARAMS)
        if self.covariance is not None:
            self.covariance = np.asarray(self.covariance, dtype=float).reshape(N_PARAMS, N_PARAMS)
            if self.sigma is None:
                self.sigma = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        if self.sigma is not None:
            self.sigma = np.asarray(self.sigma, dtype=float).reshape(N_PARAMS)

    def __getitem__(self, name: str) -> float:
        return float(self.values[INDEX[name]])

    @classmethod
    def from_dict(cls, values: dict[str, float]) -> "ParameterSet":
        missing = [n for n in NAMES if n not in values]
        if missing:
            raise ParameterTableError(f"missing parameters: {', '.join(missing)}")
        return cls(np.array([values[n] for n in NAMES]))

    def to_frame(self, truth: "ParameterSet | None" = None) -> pd.DataFrame:
        """The parameter table as a DataFrame (``truth`` adds truth and natural-unit error)."""
        frame = pd.DataFrame({"parameter": NAMES, "unit": UNITS, "value": self.values,
                              "sigma": self.sigma if self.sigma is not None else np.nan})
        if self.sigma is not None:
            frame["sigma_natural"] = self.sigma / NATURAL_SCALE / np.where(SCALE_MASK, np.abs(self.values), 1.0)
            frame["natural_unit"] = NATURAL_UNITS
        if truth is not None:
            frame["truth"] = truth.values
            frame["error_natural"] = natural_errors(self.values, truth.values)
            frame["natural_unit"] = NATURAL_UNITS
        return frame


def table_text(params: ParameterSet, truth: ParameterSet | None = None, as_truth: bool = False) -> str:
    """The parameter table CSV (header ``parameter,unit,value,sigma``, more columns after).

    ``as_truth`` gives a truth file (``parameter,unit,value``).
    """
    frame = params.to_frame(truth)
    if as_truth:
        frame = frame[["parameter", "unit", "value"]]
    return frame.to_csv(index=False, float_format="%.12g", na_rep="")


def write_table(path: str | Path, params: ParameterSet, truth: ParameterSet | None = None,
                as_truth: bool = False) -> Path:
    """Write the parameter table CSV (:func:`table_text`) atomically."""
    from .io import atomic_write_text

    return atomic_write_text(path, table_text(params, truth, as_truth))


def read_table(path: str | Path) -> ParameterSet:
    """Read a parameter table or truth file; values in other known units are converted to SI.

    Raises
    ------
    ParameterTableError
        Naming the file and line of a missing, unknown, repeated or non-finite entry.
    """
    path = Path(path)
    try:
        frame = pd.read_csv(path, dtype={"parameter": str, "unit": str})
    except FileNotFoundError:
        raise ParameterTableError(f"{path}: no such parameter table") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise ParameterTableError(f"{path}: not a CSV parameter table ({exc})") from None
    for col in ("parameter", "unit", "value"):
        if col not in frame.columns:
            raise ParameterTableError(f"{path}: missing column {col!r} (header must start parameter,unit,value)")
    values: dict[str, float] = {}
    sigmas: dict[str, float] = {}
    for row, rec in enumerate(frame.itertuples(index=False)):
        line = row + 2
        name = str(rec.parameter).strip()
        if name not in INDEX:
            raise ParameterTableError(f"{path}, line {line}: unknown parameter {name!r}")
        if name in values:
            raise ParameterTableError(f"{path}, line {line}: parameter {name!r} given twice")
        unit = str(rec.unit).strip()
        if unit not in TO_SI:
            raise ParameterTableError(f"{path}, line {line}: unknown unit {unit!r} for {name}")
        if TO_SI[unit] != TO_SI[UNITS[INDEX[name]]] and _dimension(unit) != _dimension(UNITS[INDEX[name]]):
            raise ParameterTableError(
                f"{path}, line {line}: unit {unit!r} does not fit {name} (expected {UNITS[INDEX[name]]})"
            )
        try:
            value = float(rec.value)
        except (TypeError, ValueError):
            raise ParameterTableError(f"{path}, line {line}: value {rec.value!r} of {name} is not a number") from None
        if not np.isfinite(value):
            raise ParameterTableError(f"{path}, line {line}: value of {name} is not finite")
        values[name] = value * TO_SI[unit]
        sigma = getattr(rec, "sigma", np.nan)
        try:
            sigmas[name] = float(sigma) * TO_SI[unit]
        except (TypeError, ValueError):
            sigmas[name] = np.nan
    missing = [n for n in NAMES if n not in values]
    if missing:
        raise ParameterTableError(f"{path}: missing parameters {', '.join(missing)}")
    sig = np.array([sigmas[n] for n in NAMES])
    return ParameterSet(np.array([values[n] for n in NAMES]), sigma=None if np.all(np.isnan(sig)) else sig)


def _dimension(unit: str) -> str:
    if unit in ("m/s^2", "ug", "mg"):
        return "accel"
    if unit in ("rad/s", "deg/h", "deg/s"):
        return "rate"
    if unit.endswith("/pulse"):
        return "m/s/pulse" if unit.startswith("m/s") else "angle/pulse"
    return "angle"
