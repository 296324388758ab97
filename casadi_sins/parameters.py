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

from .frames import G0
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


# --------------------------------------------------------------------------- terms beyond the 21
@dataclasses.dataclass(frozen=True)
class ParameterGroup:
    """A group of optional output-model parameters: names, SI unit, natural unit, prior, meaning.

    Everything that handles parameters (table, reports, solvers, simulator, Monte Carlo) reads the
    extra rows from here; the 21 of the paper are always first.
    """

    key: str
    label: str
    names: tuple[str, ...]
    unit: str  # SI, as written in the parameter table
    natural_unit: str
    natural_scale: float  # SI per natural unit
    meaning: str
    prior: float = 0.0  # value when the group is not estimated


EXTRA_GROUPS = {
    "quadratic": ParameterGroup(
        "quadratic", "accel quadratic scale", ("accel_quadratic_x", "accel_quadratic_y", "accel_quadratic_z"),
        "s^2/m", "ug/g^2", 1e-6 / G0,
        "k2 of each accelerometer: its output is a + k2 a^2 for the sensed specific force a (per axis)"),
    "lever": ParameterGroup(
        "lever", "accel lever arms across the sensing axes (size effect)",
        ("accel_x_lever_y", "accel_x_lever_z", "accel_y_lever_x", "accel_y_lever_z"),
        "m", "mm", 1e-3,
        "position of the x and y accelerometers relative to the z accelerometer (the navigation point), "
        "across their sensing axes; each senses w_dot x p + w x (w x p) along its axis"),
    "lever_along": ParameterGroup(
        "lever_along", "accel lever arms along the sensing axes",
        ("accel_x_lever_x", "accel_y_lever_y"),
        "m", "mm", 1e-3,
        "position of the x (y) accelerometer along its own axis: seen only through the centripetal term, "
        "-(w_y^2 + w_z^2) p_x; single-axis turns make it one with the time offset"),
    "timing": ParameterGroup(
        "timing", "gyro/accel time offset", ("accel_time_offset",), "s", "ms", 1e-3,
        "the accelerometer samples describe the specific force this much later than the gyro samples "
        "(f -> f - tau w x f)"),
}
#: The parameter models: the paper's 21, and with every extra group.
MODELS = {"21": (), "extended": tuple(EXTRA_GROUPS)}
EXTRA_NAMES = tuple(n for g in EXTRA_GROUPS.values() for n in g.names)
ALL_NAMES = NAMES + EXTRA_NAMES


def model_names(extras=()) -> tuple[str, ...]:
    """The 21 names followed by those of the given extra groups (in registry order)."""
    unknown = set(extras) - set(EXTRA_GROUPS)
    if unknown:
        raise ValueError(f"unknown parameter group(s) {', '.join(sorted(unknown))}; known: {', '.join(EXTRA_GROUPS)}")
    return NAMES + tuple(n for key, g in EXTRA_GROUPS.items() if key in extras for n in g.names)


def extra_group_of(name: str) -> ParameterGroup | None:
    return next((g for g in EXTRA_GROUPS.values() if name in g.names), None)


def groups_in(names) -> tuple[str, ...]:
    """The extra groups present in a list of names."""
    return tuple(key for key, g in EXTRA_GROUPS.items() if any(n in names for n in g.names))


def unit_of(name: str) -> str:
    group = extra_group_of(name)
    return group.unit if group else UNITS[INDEX[name]]


def natural_unit_of(name: str) -> str:
    group = extra_group_of(name)
    return group.natural_unit if group else NATURAL_UNITS[INDEX[name]]


def natural_scale_of(names) -> np.ndarray:
    """SI size of each name's natural unit (scale factors: 1e-6, relative to the value)."""
    return np.array([extra_group_of(n).natural_scale if extra_group_of(n) else NATURAL_SCALE[INDEX[n]]
                     for n in names])


def scale_mask_of(names) -> np.ndarray:
    return np.array(["_scale_" in n for n in names])


def natural_value_of(name: str, value: float) -> tuple[float, str]:
    """A parameter's *value* in the unit an engineer reads: the natural unit of its error, except scale
    factors, whose value is a pulse weight (gyro arcsec/pulse, accelerometer m/s/pulse)."""
    if name.startswith("gyro_scale"):
        return value / ARCSEC, "arcsec/pulse"
    if name.startswith("accel_scale"):
        return value, "m/s/pulse"
    return value / float(natural_scale_of([name])[0]), natural_unit_of(name)


# --------------------------------------------------------------------------- model
def sensor_matrices(p):
    """``(K_a, S_a, B_a, K_g, S_g, B_g)`` of a parameter vector (CasADi or NumPy, SI).

    ``S`` and ``B`` are 3-vectors, ``K`` the 3x3 misalignment matrices of eq. 1
    (unit diagonal; ``K_a`` lower triangular; row = sensor axis).
    """
    if not isinstance(p, (ca.SX, ca.MX, ca.DM)):
        p = ca.DM(np.asarray(p, dtype=float).ravel()[:N_PARAMS])

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


def compensate_expr(dn_g, dn_a, p, dt, accel_correction=None):
    """Increments ``(dtheta, dv)`` from raw pulses: the exact inverse of eq. 1.

    ``dn_g``, ``dn_a`` may be 3 x n matrices of pulse sums over n intervals with ``dt`` a 1 x n row
    (the model is linear, so summed pulses compensate exactly to summed increments).
    ``accel_correction`` (3 x n) is added before ``K_a^-1``: the terms beyond the 21
    (:func:`extended.correction_expr`).
    """
    k_a, s_a, b_a, k_g, s_g, b_g = sensor_matrices(p)
    dtheta = ca.solve(k_g, ca.diag(s_g) @ dn_g - b_g @ dt)
    sensed = ca.diag(s_a) @ dn_a - b_a @ dt
    dv = ca.solve(k_a, sensed if accel_correction is None else sensed + accel_correction)
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
    core = np.asarray(p, dtype=float)[:N_PARAMS]  # the extras act through extended.py, not here
    m_a, c_a, m_b, c_b = (np.asarray(x) for x in _affine_function(which)(core, dt))
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


def parameter_errors(estimate: np.ndarray, truth: np.ndarray, names=NAMES) -> np.ndarray:
    """Errors of an estimate in SI-like form (scale factors relative), ordered like ``names``.

    Biases, misalignments and extra terms: ``estimate - truth``; scale factors
    ``estimate/truth - 1`` (the ``t_ii`` of the paper).  Divide by
    :func:`natural_scale_of` for natural units.
    """
    estimate, truth = np.asarray(estimate, float), np.asarray(truth, float)
    err = estimate - truth
    mask = scale_mask_of(names)
    err[mask] = estimate[mask] / truth[mask] - 1.0
    return err


def natural_errors(estimate, truth, names=None) -> np.ndarray:
    """Errors of an estimate in natural units (ug, ppm, arcsec, deg/h; mm, ms, ug/g^2 for the extras).

    ``estimate`` and ``truth`` may be arrays (ordered like ``names``, default the 21) or
    :class:`ParameterSet` objects: then the estimate's names, with the truth's value or the group's prior
    (0) where the truth lacks a name (a truth file of the 21 against an extended estimate).
    """
    if isinstance(estimate, ParameterSet):
        names = estimate.names
        truth = truth.aligned(names) if isinstance(truth, ParameterSet) else truth
        estimate = estimate.values
    elif isinstance(truth, ParameterSet):
        truth = truth.aligned(names or NAMES)
    names = names or NAMES
    return parameter_errors(estimate, truth, names) / natural_scale_of(names)


# --------------------------------------------------------------------------- table
class ParameterTableError(ValueError):
    """A parameter table that cannot be read."""


@dataclasses.dataclass
class ParameterSet:
    """Values of the parameters (SI, order of ``names``: the 21 of :data:`NAMES`, then any extra groups)
    with optional uncertainty.

    Attributes
    ----------
    values : ndarray (n,)
    sigma : ndarray (n,) or None
        1-sigma uncertainty of each value, SI.
    covariance : ndarray (n, n) or None
        Full covariance in SI; when given, ``sigma`` is its diagonal root.
    names : tuple of str
        :data:`NAMES` (the paper's model) or :func:`model_names` of some extra groups.
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
        return tuple(unit_of(n) for n in self.names)

    @property
    def natural_units(self) -> tuple[str, ...]:
        return tuple(natural_unit_of(n) for n in self.names)

    def natural_sigma(self) -> np.ndarray:
        """1-sigma of each parameter in the natural unit of its error (scale factors relative, ppm)."""
        if self.sigma is None:
            return np.full(len(self.names), np.nan)
        mask = scale_mask_of(self.names)
        return self.sigma / natural_scale_of(self.names) / np.where(mask, np.abs(self.values), 1.0)

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
        return np.array([lookup[n] if n in lookup else extra_group_of(n).prior for n in names])

    @classmethod
    def from_dict(cls, values: dict[str, float]) -> "ParameterSet":
        """From ``{name: SI value}``: all 21, and every name of each extra group that appears."""
        missing = [n for n in NAMES if n not in values]
        names = model_names(groups_in(values))
        missing += [n for n in names[N_PARAMS:] if n not in values]
        if missing:
            raise ParameterTableError(f"missing parameters: {', '.join(missing)}")
        return cls(np.array([values[n] for n in names]), names=names)

    def to_frame(self, truth: "ParameterSet | None" = None) -> pd.DataFrame:
        """The parameter table as a DataFrame (``truth`` adds truth and natural-unit error)."""
        names = self.names
        natural = [natural_unit_of(n) for n in names]
        frame = pd.DataFrame({"parameter": names, "unit": [unit_of(n) for n in names], "value": self.values,
                              "sigma": self.sigma if self.sigma is not None else np.nan})
        mask = scale_mask_of(names)
        if self.sigma is not None:
            frame["sigma_natural"] = self.sigma / natural_scale_of(names) / np.where(mask, np.abs(self.values), 1.0)
            frame["natural_unit"] = natural
        if truth is not None:
            frame["truth"] = truth.aligned(names)
            frame["error_natural"] = natural_errors(self, truth)
            frame["natural_unit"] = natural
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
        if name not in INDEX and extra_group_of(name) is None:
            raise ParameterTableError(f"{path}, line {line}: unknown parameter {name!r}")
        if name in values:
            raise ParameterTableError(f"{path}, line {line}: parameter {name!r} given twice")
        unit = str(rec.unit).strip()
        if unit not in TO_SI:
            raise ParameterTableError(f"{path}, line {line}: unknown unit {unit!r} for {name}")
        expected = unit_of(name)
        if TO_SI[unit] != TO_SI[expected] and _dimension(unit) != _dimension(expected):
            raise ParameterTableError(f"{path}, line {line}: unit {unit!r} does not fit {name} (expected {expected})")
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
    names = model_names(groups_in(values))
    missing = [n for n in names if n not in values]
    if missing:
        raise ParameterTableError(f"{path}: missing parameters {', '.join(missing)}")
    sig = np.array([sigmas[n] for n in names])
    return ParameterSet(np.array([values[n] for n in names]), sigma=None if np.all(np.isnan(sig)) else sig,
                        names=names)


def _dimension(unit: str) -> str:
    if unit in ("m/s^2", "ug", "mg"):
        return "accel"
    if unit in ("rad/s", "deg/h", "deg/s"):
        return "rate"
    if unit.endswith("/pulse"):
        return "m/s/pulse" if unit.startswith("m/s") else "angle/pulse"
    if unit in ("s^2/m", "ug/g^2"):
        return "quadratic"
    if unit in ("m", "mm", "cm"):
        return "length"
    if unit in ("s", "ms"):
        return "time"
    return "angle"
