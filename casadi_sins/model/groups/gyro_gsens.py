"""Gyro g-sensitivity ``G`` (3 x 3): gyro ``i`` outputs ``(G f)_i`` more, ``f`` the body specific force
(``G_ij``: gyro axis ``i``, specific-force axis ``j``; SI rad/s per m/s^2, natural deg/h/g).  Extending
eq. 1::

    dN_g = diag(S_g)^-1 (K_g dtheta + G dv + B_g dt)

Compensation over a step: ``c_g = -G dv`` with ``dv`` the step's specific-force increment (compensated
with the 21; the product with ``G`` makes the difference second order).  At rest it is a bias that
changes with the position (``G g`` for the up axis), so the static gyro means separate it from ``B_g``
when the positions put each axis up and down.  PSINS: ``gSens = K_g^-1 G`` (compensation
``wm' = Kg wm - eb ts - gSens vm``).
"""

from __future__ import annotations

import numpy as np

from ...core.earth import G0
from ...core.units import DEG_PER_H
from ..catalog import GROUP_LABELS
from .base import ParameterGroup, value

NAMES = tuple(f"gyro_gsens_{i}{j}" for i in "xyz" for j in "xyz")


def matrix(values: dict) -> np.ndarray:
    """``G`` (3 x 3, SI) from the values (absent entries 0)."""
    return np.array([[float(value(values, f"gyro_gsens_{i}{j}")) for j in "xyz"] for i in "xyz"])


def correction(values: dict, regressors: dict, dtheta, dv) -> list:
    """``-(G dv)_i`` per gyro axis."""
    return [-sum(value(values, f"gyro_gsens_{i}{j}") * dv[k, :] for k, j in enumerate("xyz")) for i in "xyz"]


def truth(nodes, values: dict) -> np.ndarray:
    """``G int f dt`` per sample."""
    return nodes.integral(nodes.force) @ matrix(values).T


def psins(values: dict, k_g_inv) -> dict:
    return {"gSens": (k_g_inv @ matrix(values), "rad/s per m/s^2")}


def c_terms(values: dict, k_g_inv) -> list:
    return [("G_g", k_g_inv @ matrix(values), "g-sensitivity: dtheta -= G_g dv (dv in m/s)")]


GROUP = ParameterGroup("gyro_gsens", GROUP_LABELS["gyro_gsens"], NAMES, "rad/s/(m/s^2)", "deg/h/g", DEG_PER_H / G0,
                       sensor="gyro", core=False, correction=correction, truth=truth, psins=psins, c_terms=c_terms,
                       drop_rank=6, weak_level=0.01,
                       separated_by="static positions with every axis up and down, and horizontal",
                       meaning="G_ij: gyro i outputs G_ij f_j more for the body specific force f (axis j)")
