"""The sensor-error columns: what an error of each parameter adds to the compensated rate and specific force.

For the parameters ``names`` (the paper's 21, then any extra groups of the registry, :mod:`model.registry`)
and an error state ``x`` of them (true minus estimated; scale factors relative, ``t_ii = S_hat/S - 1``), the
compensated outputs of a unit err, per unit time in the body frame, by::

    d_w = G_w(w, f) x,        d_f = G_f(w, f) x

with ``w`` the body rate (the Earth rate and any turntable's rate) and ``f`` the specific force.  The 21's
columns are eqs. 5-12 of Kang et al. (2013), ``d_w = T_g w + eps``, ``d_f = T_a f + Delta``
(:func:`nav.errormodel.input_sensitivity`); an extra group's are its own correction (:mod:`model.groups`,
linear in the group's values) at a unit value, from the regressors of the motion (:mod:`model.regressors`).
``rest_rate`` is the part of the rate no turntable makes (the Earth rate in the body): the time offset's
regressor sees only the turning part.  Written once here, these columns are what the error budget, the
rotation-modulation study and the schedule design propagate (:mod:`nav.errorstate`).
"""

from __future__ import annotations

import numpy as np

from ..model.registry import N_PARAMS, group_of, regressor_blocks
from ..model.regressors import layout, sample_rows
from .errormodel import input_sensitivity


def _extra_columns(names: tuple[str, ...], rate: np.ndarray, force: np.ndarray, rest: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``(G_w, G_f)`` (N, 3, extras) of the extra parameters of ``names``: minus each group's correction
    (:mod:`model.groups`, linear in its values) at a unit value of the parameter, on NumPy arrays."""
    extra = names[N_PARAMS:]
    blocks = regressor_blocks(names)
    regs = sample_rows(rate, force, 1.0, blocks, rest).T
    rows = {block: regs[span] for block, span in layout(blocks).items()}
    out = {"gyro": np.zeros((len(rate), 3, len(extra))), "accel": np.zeros((len(rate), 3, len(extra)))}
    for k, name in enumerate(extra):
        group = group_of(name)
        terms = group.correction({name: 1.0}, rows, rate.T, force.T)
        out[group.sensor][:, :, k] = -np.stack([np.broadcast_to(np.asarray(term, dtype=float), (len(rate),))
                                                for term in terms], axis=1)
    return out["gyro"], out["accel"]


def error_columns(names, rate: np.ndarray, force: np.ndarray, rest_rate: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``(G_w, G_f)``: d(d_w)/dx and d(d_f)/dx in the body (module docstring), one pair per node.

    Parameters
    ----------
    names : sequence of str
        The parameters (the 21 first, then extra groups).
    rate, force : ndarray (3,) or (N, 3)
        Body rate (rad/s, a turntable's included) and specific force (m/s^2).
    rest_rate : ndarray (3,) or (N, 3), optional
        The rate without the turntable's (default ``rate``: a unit at rest).

    Returns
    -------
    (ndarray, ndarray)
        (3, n) each for one node, (N, 3, n) for N nodes.
    """
    names = tuple(names)
    single = np.ndim(rate) == 1
    rate, force = np.atleast_2d(np.asarray(rate, dtype=float)), np.atleast_2d(np.asarray(force, dtype=float))
    rest = rate if rest_rate is None else np.broadcast_to(np.asarray(rest_rate, dtype=float), rate.shape)
    gyro, accel = input_sensitivity(rate, 1.0, "gyro"), input_sensitivity(force, 1.0, "accel")
    if len(names) > N_PARAMS:
        extra_g, extra_a = _extra_columns(names, rate, force, rest)
        gyro, accel = np.concatenate([gyro, extra_g], axis=2), np.concatenate([accel, extra_a], axis=2)
    return (gyro[0], accel[0]) if single else (gyro, accel)


def body_motion(attitude: np.ndarray, earth_rate: np.ndarray, gravity: float, table_rate=None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(w, f, w_rest)`` in the body at attitudes ``C_b^n`` (3, 3) or (N, 3, 3) on a static base: the rate
    ``w = C^T w_ie + w_table`` with a turntable's rate (body, rad/s; default none), the specific force
    ``f = C^T (0, 0, g)`` (the unit turns about its centre) and the rate at rest ``w_rest = C^T w_ie``."""
    attitude = np.asarray(attitude, dtype=float)
    rest = np.swapaxes(attitude, -1, -2) @ earth_rate
    force = attitude[..., 2, :] * gravity
    rate = rest if table_rate is None else rest + table_rate
    return rate, force, rest
