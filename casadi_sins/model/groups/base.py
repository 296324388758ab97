"""What a parameter group is: its names and units, and the physics it owns.

A group of the paper's 21 is fully described by eq. 1 (:mod:`model.output`); an extra group owns
its physics here, in four functions of its module:

``correction(values, regressors, dtheta, dv) -> [row_x, row_y, row_z]``
    the term its sensor's compensation adds before ``K^-1`` (``dtheta = K_g^-1 (S_g dN_g - B_g dt + c_g)``,
    ``dv = K_a^-1 (S_a dN_a - B_a dt + c_a)``), from the step's regressor blocks
    (:mod:`model.regressors`) or from the step's increments compensated with the 21 (``dtheta``,
    ``dv``: 3 x n); CasADi or NumPy.
``truth(nodes, values) -> (N, 3)``
    for the simulator: what the group adds to its sensor's output ``K x + B dt`` over each sample, by
    quadrature over the sample's nodes (:class:`model.groups.physics.Nodes`); exact physics.
``psins(values, k_g_inv) -> {field: array}``
    its fields of the PSINS ``clbt`` struct (compensation values, the toolbox's signs).
``c_terms(values, k_g_inv) -> [(C name, matrix or vector, meaning)]``
    the per-sample compensation arrays of the firmware header, when the term has that form.
"""

from __future__ import annotations

import dataclasses
from typing import Callable


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
    sensor : {"gyro", "accel"}
        The sensor whose output the group changes (and whose compensation its correction enters).
    relative : bool
        The error is relative to the value (scale factors: ``S_hat/S - 1``).
    core : bool
        One of the paper's 21.
    prior : float
        Value when the group is not estimated.
    meaning : str
    value_unit, value_scale : str, float
        Unit and SI size in which an engineer reads the *value* (default: the natural unit).
    regressors : tuple of str
        The regressor blocks its correction reads (:mod:`model.regressors`).
    correction, truth, psins, c_terms : callable or None
        The group's physics (module docstring).
    shift, acceleration : callable or None
        For the simulator, terms that change what an accelerometer senses before its output model:
        ``shift(values) -> tau`` (its samples describe the specific force ``tau`` later) and
        ``acceleration(nodes, values) -> (N, J, 3)`` (an acceleration added at each quadrature node).
    needs_rotation_steps : bool
        Seen only through the velocity steps across rotations.
    drop_rank : int or None
        Extra groups the schedule cannot separate are dropped in increasing rank (weakest seen first).
    weak_level : float
        A 1-sigma above this (natural units) means the schedule does not determine the parameter: about
        1 % of what is known of it before any calibration (a navigation-grade unit's rough values).
    separated_by : str
        What a schedule needs to separate the group from the 21 (named when ``extended`` leaves it out).
    """

    key: str
    label: str
    names: tuple[str, ...]
    unit: str
    natural_unit: str
    natural_scale: float
    sensor: str = "accel"
    relative: bool = False
    core: bool = True
    prior: float = 0.0
    meaning: str = ""
    value_unit: str | None = None
    value_scale: float | None = None
    regressors: tuple[str, ...] = ()
    correction: Callable | None = None
    truth: Callable | None = None
    psins: Callable | None = None
    c_terms: Callable | None = None
    shift: Callable | None = None
    acceleration: Callable | None = None
    needs_rotation_steps: bool = False
    drop_rank: int | None = None
    weak_level: float = 5.0
    separated_by: str = "turns about every axis"


def axes(prefix: str, suffixes=("x", "y", "z")) -> tuple[str, ...]:
    """``prefix_x, prefix_y, prefix_z`` (or the given suffixes)."""
    return tuple(f"{prefix}_{a}" for a in suffixes)


def value(values: dict, name: str):
    """A parameter's value from ``values`` (0 when absent)."""
    return values.get(name, 0.0)
