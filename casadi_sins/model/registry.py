"""Every parameter of the output model, in one registry: the paper's 21 and the extra groups.

A :class:`ParameterGroup` says everything the rest of the package needs of a group of parameters:
names (the order of the parameter table), SI unit, natural unit of the error and its size, whether
the error is relative to the value (scale factors, ppm), the prior (value when not estimated), the
physics of the extra groups (the correction term of the compensation, for the estimator), whether
only the velocity steps across rotations show it, and in which order unobservable groups are
dropped.  Adding a group is one entry here, its physics in :mod:`model.extras`, and its tests.

The paper's 21 (Kang et al. 2013, eq. 1)::

    dN_g = diag(S_g)^-1 (K_g dtheta + B_g dt)
    dN_a = diag(S_a)^-1 (K_a dv     + B_a dt)

``K_g`` unit-diagonal with six off-diagonal misalignments, ``K_a`` unit-lower-triangular with three.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from ..core.earth import G0
from ..core.units import ARCSEC, DEG_PER_H, PPM, UG
from . import extras


@dataclasses.dataclass(frozen=True)
class ParameterGroup:
    """One group of output-model parameters.

    Attributes
    ----------
    key : str
        Short name (``"gyro_scale"``, ``"lever"``).
    label : str
        Name in reports.
    names : tuple of str
        Parameter names, in table order.
    unit : str
        SI unit of the value in the parameter table.
    natural_unit : str
        Unit of the *error* in reports (ppm of the value for scale factors).
    natural_scale : float
        SI size of one natural unit (relative for scale factors: 1e-6).
    relative : bool
        The error is relative to the value (scale factors: ``S_hat/S - 1``).
    core : bool
        One of the paper's 21.
    prior : float
        Value when the group is not estimated.
    meaning : str
    value_unit, value_scale : str, float
        Unit and SI size in which an engineer reads the *value* (default: the natural unit).
    correction : callable or None
        Extra groups: ``correction(values, regressors) -> [row_x, row_y, row_z]``, the term added to the
        sensed accelerometer increments before ``K_a^-1`` (:mod:`model.extras`).
    needs_rotation_steps : bool
        Seen only through the velocity steps across rotations.
    drop_rank : int or None
        Extra groups the schedule cannot separate are dropped in increasing rank (weakest seen first).
    weak_level : float
        A 1-sigma above this (natural units) means the schedule does not determine the parameter: about
        1 % of what is known of it before any calibration (a navigation-grade unit's rough values).
    """

    key: str
    label: str
    names: tuple[str, ...]
    unit: str
    natural_unit: str
    natural_scale: float
    relative: bool = False
    core: bool = True
    prior: float = 0.0
    meaning: str = ""
    value_unit: str | None = None
    value_scale: float | None = None
    correction: Callable | None = None
    needs_rotation_steps: bool = False
    drop_rank: int | None = None
    weak_level: float = 5.0


def _axes(prefix: str, axes=("x", "y", "z")) -> tuple[str, ...]:
    return tuple(f"{prefix}_{a}" for a in axes)


#: The registry, in table order: the paper's 21 first, then the extra groups.
GROUPS: dict[str, ParameterGroup] = {g.key: g for g in (
    ParameterGroup("accel_bias", "accel bias", _axes("accel_bias"), "m/s^2", "ug", UG,
                   meaning="B_a: accelerometer bias"),
    ParameterGroup("accel_scale", "accel scale", _axes("accel_scale"), "m/s/pulse", "ppm", PPM, relative=True,
                   value_unit="m/s/pulse", value_scale=1.0, meaning="S_a: accelerometer pulse weight"),
    ParameterGroup("accel_misalign", "accel misalignment", _axes("accel_misalign", ("yx", "zx", "zy")), "rad",
                   "arcsec", ARCSEC, meaning="K_a lower off-diagonal (row = sensor axis, column)"),
    ParameterGroup("gyro_bias", "gyro bias", _axes("gyro_bias"), "rad/s", "deg/h", DEG_PER_H, weak_level=0.01,
                   meaning="B_g: gyro bias"),
    ParameterGroup("gyro_scale", "gyro scale", _axes("gyro_scale"), "rad/pulse", "ppm", PPM, relative=True,
                   value_unit="arcsec/pulse", value_scale=ARCSEC, meaning="S_g: gyro pulse weight"),
    ParameterGroup("gyro_misalign", "gyro misalignment",
                   _axes("gyro_misalign", ("xy", "xz", "yx", "yz", "zx", "zy")), "rad", "arcsec", ARCSEC,
                   meaning="K_g off-diagonal (row = sensor axis, column)"),
    ParameterGroup("quadratic", "accel quadratic scale", _axes("accel_quadratic"), "s^2/m", "ug/g^2", 1e-6 / G0,
                   core=False, correction=extras.quadratic_correction, drop_rank=3,
                   meaning="k2 of each accelerometer: its output is a + k2 a^2 for the sensed specific force a"),
    ParameterGroup("lever", "accel lever arms across the sensing axes (size effect)",
                   ("accel_x_lever_y", "accel_x_lever_z", "accel_y_lever_x", "accel_y_lever_z"), "m", "mm", 1e-3,
                   core=False, correction=extras.lever_correction, needs_rotation_steps=True, drop_rank=1,
                   meaning="position of the x and y accelerometers relative to the z accelerometer (the navigation "
                           "point), across their sensing axes; each senses w_dot x p + w x (w x p) along its axis"),
    ParameterGroup("lever_along", "accel lever arms along the sensing axes", ("accel_x_lever_x", "accel_y_lever_y"),
                   "m", "mm", 1e-3, core=False, correction=extras.lever_correction, needs_rotation_steps=True,
                   drop_rank=0,
                   meaning="position of the x (y) accelerometer along its own axis: seen only through the centripetal "
                           "term, -(w_y^2 + w_z^2) p_x; single-axis turns make it one with the time offset"),
    ParameterGroup("timing", "gyro/accel time offset", ("accel_time_offset",), "s", "ms", 1e-3, core=False, weak_level=0.2,
                   correction=extras.timing_correction, needs_rotation_steps=True, drop_rank=2,
                   meaning="the accelerometer samples describe the specific force this much later than the gyro "
                           "samples (f -> f - tau w x f)"),
)}

CORE_GROUPS = tuple(k for k, g in GROUPS.items() if g.core)
EXTRA_GROUPS = tuple(k for k, g in GROUPS.items() if not g.core)
#: The paper's 21 names, in the order of the parameter table (and of every parameter vector).
NAMES = tuple(n for k in CORE_GROUPS for n in GROUPS[k].names)
N_PARAMS = len(NAMES)
ALL_NAMES = tuple(n for g in GROUPS.values() for n in g.names)
#: The parameter models: the paper's 21, and with every extra group.
MODELS = {"21": (), "extended": EXTRA_GROUPS}
#: Extra groups in the order they are dropped when the schedule cannot separate them.
DROP_ORDER = tuple(sorted((k for k in EXTRA_GROUPS if GROUPS[k].drop_rank is not None),
                          key=lambda k: GROUPS[k].drop_rank))
_GROUP_OF = {n: g for g in GROUPS.values() for n in g.names}


def _span(key: str) -> slice:
    start = NAMES.index(GROUPS[key].names[0])
    return slice(start, start + len(GROUPS[key].names))


ACCEL_BIAS, ACCEL_SCALE, ACCEL_MISALIGN = _span("accel_bias"), _span("accel_scale"), _span("accel_misalign")
GYRO_BIAS, GYRO_SCALE, GYRO_MISALIGN = _span("gyro_bias"), _span("gyro_scale"), _span("gyro_misalign")
#: (row, column) of each misalignment in K_a and K_g, from the names' last two letters.
ACCEL_MISALIGN_ENTRIES = tuple(("xyz".index(n[-2]), "xyz".index(n[-1])) for n in GROUPS["accel_misalign"].names)
GYRO_MISALIGN_ENTRIES = tuple(("xyz".index(n[-2]), "xyz".index(n[-1])) for n in GROUPS["gyro_misalign"].names)


def group_of(name: str) -> ParameterGroup:
    """The group a parameter belongs to; ``KeyError`` naming it when unknown."""
    try:
        return _GROUP_OF[name]
    except KeyError:
        raise KeyError(f"unknown parameter {name!r}") from None


def is_known(name: str) -> bool:
    """Whether ``name`` is a parameter of the registry."""
    return name in _GROUP_OF


def model_names(extras=()) -> tuple[str, ...]:
    """The 21 names followed by those of the given extra groups (in registry order)."""
    unknown = set(extras) - set(EXTRA_GROUPS)
    if unknown:
        raise ValueError(f"unknown parameter group(s) {', '.join(sorted(unknown))}; known: {', '.join(EXTRA_GROUPS)}")
    return NAMES + tuple(n for key in EXTRA_GROUPS if key in extras for n in GROUPS[key].names)


def groups_in(names) -> tuple[str, ...]:
    """The extra groups present in a list of names, in registry order."""
    present = set(names)
    return tuple(key for key in EXTRA_GROUPS if any(n in present for n in GROUPS[key].names))


def unit_of(name: str) -> str:
    """SI unit of a parameter's value, as in the parameter table."""
    return group_of(name).unit


def natural_unit_of(name: str) -> str:
    """Natural unit of a parameter's error (ppm of the value for scale factors)."""
    return group_of(name).natural_unit


def natural_scale_of(names) -> np.ndarray:
    """SI size of each name's natural unit (scale factors: 1e-6, relative to the value)."""
    return np.array([group_of(n).natural_scale for n in names])


def relative_mask(names) -> np.ndarray:
    """True where a parameter's error is relative to its value (the scale factors)."""
    return np.array([group_of(n).relative for n in names], dtype=bool)


def natural_value_of(name: str, value: float) -> tuple[float, str]:
    """A parameter's *value* in the unit an engineer reads: the natural unit of its error, except scale
    factors, whose value is a pulse weight (gyro arcsec/pulse, accelerometer m/s/pulse)."""
    group = group_of(name)
    if group.value_unit is not None:
        return value / group.value_scale, group.value_unit
    return value / group.natural_scale, group.natural_unit


#: (label, slice, natural unit) of the six groups of the 21, for reports and plots.
CORE_SPANS = tuple((GROUPS[k].label, _span(k), GROUPS[k].natural_unit) for k in CORE_GROUPS)
NATURAL_SCALE = natural_scale_of(NAMES)
NATURAL_UNITS = tuple(natural_unit_of(n) for n in NAMES)
SCALE_MASK = relative_mask(NAMES)
