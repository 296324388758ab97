"""Gyro scale-factor asymmetry ``A``: gyro ``i`` outputs ``A_i |w_i|`` more (the scale factor differs by
``2 A_i`` between positive and negative rates; natural ppm, the term ``modulate`` uses).  Extending eq. 1::

    dN_g = diag(S_g)^-1 (K_g dtheta + A |dtheta| + B_g dt)

Compensation over a step: ``c_g,i = -A_i |dtheta_i|`` with the step's increment compensated with the 21
(a step does not turn through zero rate).  Turns of one sense only make it one with the scale factor:
the schedule needs turns of both senses about each axis.  PSINS has no such field.
"""

from __future__ import annotations

import numpy as np

from ...core.units import PPM
from ..catalog import GROUP_LABELS
from .base import ParameterGroup, axes, value

NAMES = axes("gyro_scale_asym")


def correction(values: dict, regressors: dict, dtheta, dv) -> list:
    """``-A_i |dtheta_i|`` per gyro axis."""
    return [-value(values, n) * abs(dtheta[i, :]) for i, n in enumerate(NAMES)]


def truth(nodes, values: dict) -> np.ndarray:
    """``A_i int |w_i| dt`` per sample."""
    return np.array([float(value(values, n)) for n in NAMES]) * nodes.integral(np.abs(nodes.rate))


def c_terms(values: dict, k_g_inv) -> list:
    return [("A_g", k_g_inv @ np.diag([float(value(values, n)) for n in NAMES]),
             "scale asymmetry: dtheta -= A_g |dtheta| (per axis, before this term)")]


GROUP = ParameterGroup("gyro_asym", GROUP_LABELS["gyro_asym"], NAMES, "ratio", "ppm", PPM, sensor="gyro",
                       core=False, correction=correction, truth=truth, c_terms=c_terms, needs_rotation_steps=True,
                       drop_rank=5, weak_level=1.0, separated_by="turns of both senses about every axis",
                       meaning="A_i: gyro i outputs A_i |w_i| more (its scale factor is 1 + A_i larger for positive "
                               "than for negative rates, 1 - A_i)")
