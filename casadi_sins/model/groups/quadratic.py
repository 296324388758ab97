"""Accelerometer quadratic scale ``k2``: accelerometer ``i`` outputs ``a_i + k2_i a_i^2`` for the sensed
specific force ``a``.

Compensation over a step: ``c_i = -k2_i Q2_i`` with ``Q2 = sum a_k^2 dt`` (:mod:`model.regressors`).
PSINS: ``Ka2 = -k2`` (its data are ``f - Ka2 f^2``).
"""

from __future__ import annotations

import numpy as np

from ...core.earth import G0
from ..catalog import GROUP_LABELS
from .base import ParameterGroup, axes, value

NAMES = axes("accel_quadratic")


def correction(values: dict, regressors: dict, dtheta, dv) -> list:
    """``-k2_i Q2_i`` per axis."""
    return [-value(values, n) * regressors["Q2"][i, :] for i, n in enumerate(NAMES)]


def truth(nodes, values: dict) -> np.ndarray:
    """``k2_i int a_i^2 dt`` per sample."""
    return np.array([value(values, n) for n in NAMES]) * nodes.integral(nodes.sensed**2)


def psins(values: dict, k_g_inv) -> dict:
    return {"Ka2": (np.array([0.0 - value(values, n) for n in NAMES]), "s^2/m")}


GROUP = ParameterGroup("quadratic", GROUP_LABELS["quadratic"], NAMES, "s^2/m", "ug/g^2", 1e-6 / G0,
                       core=False, regressors=("Q2",), correction=correction, truth=truth, psins=psins, drop_rank=3,
                       separated_by="static positions with every accelerometer axis vertical and horizontal",
                       meaning="k2 of each accelerometer: its output is a + k2 a^2 for the sensed specific force a")
