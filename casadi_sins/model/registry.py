"""Every parameter of the output model, in one registry: the paper's 21 and the extra groups.

Each group is a :class:`model.groups.base.ParameterGroup` of its own module under :mod:`model.groups`:
names (the order of the parameter table), SI unit, natural unit of the error and its size, whether
the error is relative to the value (scale factors, ppm), the prior (value when not estimated), the
sensor it acts on and its physics (the correction of the compensation, the regressor blocks it reads,
the simulator's truth, its export fields), whether only the velocity steps across rotations show it,
and in which order unobservable groups are dropped.  Adding a group is its module, one line in
:data:`GROUPS`, and its tests.

The paper's 21 (Kang et al. 2013, eq. 1)::

    dN_g = diag(S_g)^-1 (K_g dtheta + B_g dt)
    dN_a = diag(S_a)^-1 (K_a dv     + B_a dt)

``K_g`` unit-diagonal with six off-diagonal misalignments, ``K_a`` unit-lower-triangular with three.
"""

from __future__ import annotations

import numpy as np

from .catalog import FIXED_MODELS, GROUP_LABELS, PAPER_GROUPS
from .groups import cross_quadratic, gyro_asym, gyro_gsens, lever, paper, quadratic, timing
from .groups.base import ParameterGroup

#: The registry, in table order: the paper's 21 first, then the extra groups (one line each).
GROUPS: dict[str, ParameterGroup] = {g.key: g for g in (
    *paper.GROUPS,
    quadratic.GROUP,
    lever.GROUP,
    lever.ALONG_GROUP,
    timing.GROUP,
    gyro_gsens.GROUP,
    gyro_asym.GROUP,
    cross_quadratic.GROUP,
)}

CORE_GROUPS = tuple(k for k, g in GROUPS.items() if g.core)
EXTRA_GROUPS = tuple(k for k, g in GROUPS.items() if not g.core)
if tuple(GROUPS) != tuple(GROUP_LABELS) or CORE_GROUPS != PAPER_GROUPS:  # the names the help lists (light)
    raise ImportError("model.catalog does not list the registry's groups in table order: add the new group there")
#: The paper's 21 names, in the order of the parameter table (and of every parameter vector).
NAMES = tuple(n for k in CORE_GROUPS for n in GROUPS[k].names)
N_PARAMS = len(NAMES)
ALL_NAMES = tuple(n for g in GROUPS.values() for n in g.names)
#: The parameter models: the paper's 21, and with every extra group.
MODELS = {"21": (), "extended": EXTRA_GROUPS}
if tuple(MODELS) != FIXED_MODELS:  # the models the help offers (light)
    raise ImportError("model.catalog.FIXED_MODELS does not list the registry's models")
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


def regressor_blocks(names) -> tuple[str, ...]:
    """The regressor blocks (:mod:`model.regressors`) the extra groups present in ``names`` read."""
    return tuple(sorted({b for key in groups_in(names) for b in GROUPS[key].regressors}))


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


def error_scale(names, values) -> np.ndarray:
    """SI size of one unit of each parameter's error at ``values``: ``|value|`` where the error is relative
    (scale factors: ``t_ii = S_hat/S - 1``), else 1."""
    return np.where(relative_mask(names), np.abs(np.asarray(values, dtype=float)), 1.0)


def natural_size(names, values) -> np.ndarray:
    """SI size of one natural unit of each parameter's error at ``values`` (a scale factor's ppm is 1e-6 of
    its value): divide an SI error or sigma by it for natural units."""
    return natural_scale_of(names) * error_scale(names, values)


def relative_covariance(names, values, covariance) -> np.ndarray:
    """The covariance of the errors in the error-state convention (scale factors relative, ``t_ii``) from the
    covariance (SI) of the parameters ``names`` about ``values``."""
    scale = error_scale(names, values)
    return np.asarray(covariance, dtype=float) / np.outer(scale, scale)


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
