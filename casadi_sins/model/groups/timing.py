"""Gyro/accelerometer time offset ``tau``: the accelerometer samples describe the specific force ``tau``
later than the gyro samples (``f -> f(t + tau)``, to first order ``f - tau w x f`` for ``f`` fixed in the
navigation frame).

Compensation over a step: ``c = tau X`` with ``X = sum ((dtheta_k - w_s dt) x dv_k) / dt``
(:mod:`model.regressors`).  PSINS: ``tGA = tau``.
"""

from __future__ import annotations

import numpy as np

from ..catalog import GROUP_LABELS
from .base import ParameterGroup, value

NAMES = ("accel_time_offset",)


def correction(values: dict, regressors: dict, dtheta, dv) -> list:
    """``tau X_i`` per axis."""
    return [value(values, NAMES[0]) * regressors["X"][i, :] for i in range(3)]


def shift(values: dict) -> float:
    return float(value(values, NAMES[0]))


def psins(values: dict, k_g_inv) -> dict:
    return {"tGA": (np.array(float(value(values, NAMES[0]))), "s")}


GROUP = ParameterGroup("timing", GROUP_LABELS["timing"], NAMES, "s", "ms", 1e-3, core=False, weak_level=0.2,
                       regressors=("X",), correction=correction, shift=shift, psins=psins,
                       needs_rotation_steps=True, drop_rank=2,
                       meaning="the accelerometer samples describe the specific force this much later than the gyro "
                               "samples (f -> f - tau w x f)")
