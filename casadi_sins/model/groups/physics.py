"""The simulator's exact physics of the extra groups: quadrature over each sample's nodes.

Each sample ``[t0, t1]`` gets Gauss-Legendre nodes; :class:`Nodes` holds the body rate, its derivative
and the specific force at the nodes (shifted by the groups' time shift), and what the accelerometers
sense there (the force plus the groups' accelerations).  Each group's ``truth`` integrates its output
term over the nodes (:mod:`model.groups.base`).
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass
class Nodes:
    """Quadrature nodes of N samples (J nodes each).

    Attributes
    ----------
    weights : ndarray (N, J)
    rate, rate_dot, force : ndarray (N, J, 3)
        Body rate, its derivative and the specific force at the navigation point (body frame, SI).
    sensed : ndarray (N, J, 3)
        What the accelerometers sense: ``force`` plus the groups' accelerations (lever arms).
    """

    weights: np.ndarray
    rate: np.ndarray
    rate_dot: np.ndarray
    force: np.ndarray
    sensed: np.ndarray

    def integral(self, values: np.ndarray) -> np.ndarray:
        """``int x dt`` over each sample of values (N, J, ...) at the nodes."""
        return np.einsum("nj,nj...->n...", self.weights, values)


def quadrature_nodes(kinematics, t0: np.ndarray, t1: np.ndarray, shift: float = 0.0, nodes: int = 6) -> Nodes:
    """The Gauss-Legendre nodes of the samples ``[t0, t1]`` (``nodes`` each), moved ``shift`` s later, with the
    motion there (``kinematics(t) -> (C_b^n, w_b, w_dot_b, f_b)``); what the accelerometers sense is the force.
    ``nodes.integral(nodes.rate)`` and ``nodes.integral(nodes.force)`` are the true increments."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    points = t0[:, None] + (t1 - t0)[:, None] * (1.0 + x[None, :]) / 2.0 + shift
    weights = (t1 - t0)[:, None] * w[None, :] / 2.0
    _, rate, rate_dot, force = kinematics(points)
    return Nodes(weights, rate, rate_dot, force, force)


def sensed_outputs(kinematics, t0: np.ndarray, t1: np.ndarray, values: dict, groups, nodes: int = 6):
    """What the extra groups make of each sample ``[t0, t1]``: ``(dv_f, gyro_extra, accel_extra)``.

    ``kinematics(t)`` gives ``(C_b^n, w_b, w_dot_b, f_b)`` at times ``t`` (any shape); ``values`` maps the
    extra parameters to their true values; ``groups`` are the extra groups (:mod:`model.groups`).
    ``dv_f`` (N, 3) is the specific-force increment at the (shifted) nodes, the others what the groups add
    to the gyro and accelerometer outputs ``K x + B dt`` (SI increments, (N, 3) each).
    """
    own = {g.key: {n: values[n] for n in g.names if n in values} for g in groups}  # each group its own names
    tau = sum(float(g.shift(own[g.key])) for g in groups if g.shift is not None)
    at = quadrature_nodes(kinematics, t0, t1, tau, nodes)
    force = at.force
    sensed = force.copy()
    for g in groups:
        if g.acceleration is not None:
            sensed = sensed + g.acceleration(at, own[g.key])
    at.sensed = sensed
    extra = {"gyro": np.zeros((len(t0), 3)), "accel": np.zeros((len(t0), 3))}
    for g in groups:
        if g.truth is not None:
            extra[g.sensor] = extra[g.sensor] + g.truth(at, own[g.key])
    return at.integral(force), extra["gyro"], extra["accel"]
