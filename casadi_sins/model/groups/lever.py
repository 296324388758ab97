"""Inner lever arms of the x and y accelerometers (size effect), relative to the z accelerometer (the
navigation point): accelerometer ``i`` at ``p_i`` senses ``e_i . (w_dot x p_i + w x (w x p_i))`` more.

Compensation over a step: ``c_i = -L_i(p_i)``, ``L_i = (e_i x dw + M[i, :]) . p_i`` with the rate change
``dw`` over the step and the centripetal sums ``M`` (:mod:`model.regressors`).  Two groups: across the
sensing axes, and along them (seen only through the centripetal term; single-axis turns make it one
with the time offset).  PSINS: ``rx, ry`` are compensation values, minus the positions.
"""

from __future__ import annotations

import numpy as np

from ..regressors import M_ROW
from ..catalog import GROUP_LABELS
from .base import ParameterGroup

ACROSS = ("accel_x_lever_y", "accel_x_lever_z", "accel_y_lever_x", "accel_y_lever_z")
ALONG = ("accel_x_lever_x", "accel_y_lever_y")


def positions(values: dict) -> dict[str, np.ndarray]:
    """The x and y accelerometers' positions (m) from the lever-arm values present (others 0)."""
    return {axis: np.array([float(values.get(f"accel_{axis}_lever_{c}", 0.0)) for c in "xyz"]) for axis in "xy"}


def correction(values: dict, regressors: dict, dtheta, dv) -> list:
    """``-L_i(p_i)`` for the x and y accelerometers, from whichever lever components ``values`` holds."""
    dw, m = regressors["DW"], regressors["M"]
    rows = [0 * dw[0, :] for _ in range(3)]
    for i, axis in enumerate("xy"):
        cross = {0: (0, -dw[2, :], dw[1, :]), 1: (dw[2, :], 0, -dw[0, :])}[i]  # e_i x dw
        for j, component in enumerate("xyz"):
            name = f"accel_{axis}_lever_{component}"
            if name in values:
                rows[i] = rows[i] - values[name] * (cross[j] + m[M_ROW[(min(i, j), max(i, j))], :])
    return rows


def acceleration(nodes, values: dict) -> np.ndarray:
    """What the lever arms add to the sensed acceleration at each node."""
    out = np.zeros_like(nodes.force)
    for i, p in enumerate(positions(values).values()):
        if np.any(p):
            arm = np.cross(nodes.rate_dot, p) + np.cross(nodes.rate, np.cross(nodes.rate, p))
            out[..., i] = arm[..., i]
    return out


def truth(nodes, values: dict) -> np.ndarray:
    return nodes.integral(acceleration(nodes, values))


def psins(values: dict, k_g_inv) -> dict:
    at = positions(values)
    return {"rx": (0.0 - at["x"], "m"), "ry": (0.0 - at["y"], "m"), "rz": (np.zeros(3), "m")}


_COMMON = dict(core=False, regressors=("DW", "M"), correction=correction, acceleration=acceleration, truth=truth,
               psins=psins, needs_rotation_steps=True)
GROUP = ParameterGroup("lever", GROUP_LABELS["lever"], ACROSS, "m", "mm", 1e-3,
                       drop_rank=1, **_COMMON,
                       meaning="position of the x and y accelerometers relative to the z accelerometer (the navigation "
                               "point), across their sensing axes; each senses w_dot x p + w x (w x p) along its axis")
ALONG_GROUP = ParameterGroup("lever_along", GROUP_LABELS["lever_along"], ALONG, "m", "mm", 1e-3,
                             drop_rank=0, separated_by="turns about two axes at once", **_COMMON,
                             meaning="position of the x (y) accelerometer along its own axis: seen only through the "
                                     "centripetal term, -(w_y^2 + w_z^2) p_x; single-axis turns make it one with the "
                                     "time offset")
