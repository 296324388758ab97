"""Accelerometer cross-quadratic terms: accelerometer ``i`` outputs ``a_i + sum_j k_ij a_i a_j`` (``j != i``)
for the sensed specific force ``a``: the products of its own axis with the two others (pendulous and
output-axis cross-coupling of a pendulous accelerometer).

Compensation over a step: ``c_i = -sum_j k_ij P2_ij`` with ``P2_ij = sum a_i a_j dt``
(:mod:`model.regressors`).  At rest one component of ``a`` carries gravity and the others nearly
nothing, so only the turns show these terms (``needs_rotation_steps``).  PSINS has no such field.
"""

from __future__ import annotations

import numpy as np

from ...core.earth import G0
from ..regressors import P2_ROW
from ..catalog import GROUP_LABELS
from .base import ParameterGroup, value

#: (accelerometer, other axis) of each term, in table order.
PAIRS = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
NAMES = tuple(f"accel_cross_{'xyz'[i]}_{'xyz'[j]}" for i, j in PAIRS)


def correction(values: dict, regressors: dict, dtheta, dv) -> list:
    """``-sum_j k_ij P2_ij`` per axis."""
    rows = [0 * regressors["P2"][0, :] for _ in range(3)]
    for name, (i, j) in zip(NAMES, PAIRS):
        rows[i] = rows[i] - value(values, name) * regressors["P2"][P2_ROW[(min(i, j), max(i, j))], :]
    return rows


def truth(nodes, values: dict) -> np.ndarray:
    """``sum_j k_ij int a_i a_j dt`` per sample."""
    out = np.zeros(nodes.weights.shape[:1] + (3,))
    for name, (i, j) in zip(NAMES, PAIRS):
        out[:, i] += value(values, name) * nodes.integral(nodes.sensed[..., i] * nodes.sensed[..., j])
    return out


GROUP = ParameterGroup("cross_quadratic", GROUP_LABELS["cross_quadratic"], NAMES, "s^2/m", "ug/g^2", 1e-6 / G0,
                       core=False, regressors=("P2",), correction=correction, truth=truth,
                       needs_rotation_steps=True, drop_rank=4,
                       separated_by="turns that carry gravity across two accelerometer axes (about horizontal axes)",
                       meaning="k_ij of accelerometer i: its output gains k_ij a_i a_j (j the other axis)")
