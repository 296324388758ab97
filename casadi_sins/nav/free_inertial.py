"""Free-inertial navigation on a static base: the paper's navigation check (section 2.3) and its kin.

The unit is aligned on the first minutes (eq. 14) and then navigates free-inertially: position,
transport rate, Coriolis and normal gravity at the computed position, the vertical channel held at
the known height (as navigation systems do without an altimeter).  The step reuses the
calibration's building blocks (:func:`nav.strapdown.corrected_increments`,
:func:`nav.strapdown.attitude_update`, :func:`nav.strapdown.specific_force_increment`) and the
Earth model of :mod:`core.earth`; only the position, transport-rate and Coriolis terms are added.
"""

from __future__ import annotations

import dataclasses
import functools

import casadi as ca
import numpy as np

from ..core.earth import EARTH_RATE, earth_radii, normal_gravity
from ..core.rotations import dcm_to_quat
from ..data.recording import Recording
from .alignment import align
from .navigation import compensated_increments
from .strapdown import attitude_update, corrected_increments, specific_force_increment

NAUTICAL_MILE = 1852.0
# state: q (4), v ENU (3), latitude, longitude, height (3), previous dtheta (3), previous dv (3)
FREE_STATE = 16


def free_inertial_step_expr(state, dtheta, dv, dt):
    """One free-inertial step (CasADi): state ``q, v, lat, lon, h, dtheta_prev, dv_prev`` (16)."""
    q, v = state[0:4], state[4:7]
    lat, lon, h = state[7], state[8], state[9]
    r_m, r_n = earth_radii(lat)
    w_ie = EARTH_RATE * ca.vertcat(0, ca.cos(lat), ca.sin(lat))
    w_en = ca.vertcat(-v[1] / (r_m + h), v[0] / (r_n + h), v[0] * ca.tan(lat) / (r_n + h))
    w_in_dt = (w_ie + w_en) * dt
    phi, dv_body = corrected_increments(dtheta, dv, state[10:13], state[13:16])
    gravity = ca.vertcat(0, 0, -normal_gravity(lat, h))
    v_next = v + specific_force_increment(q, dv_body, w_in_dt) + (gravity - ca.cross(2 * w_ie + w_en, v)) * dt
    v_next = ca.vertcat(v_next[0], v_next[1], 0)  # vertical channel held at the known height
    v_mid = (v + v_next) / 2
    lat_next = lat + v_mid[1] / (r_m + h) * dt
    lon_next = lon + v_mid[0] / ((r_n + h) * ca.cos(lat)) * dt
    return ca.vertcat(attitude_update(q, phi, w_in_dt), v_next, lat_next, lon_next, h, dtheta, dv)


@functools.lru_cache(maxsize=None)
def free_inertial_step() -> ca.Function:
    """``(x[16], dtheta[3], dv[3], dt) -> x``: :func:`free_inertial_step_expr` as a ``Function``."""
    x, dth, dv, dt = ca.SX.sym("x", FREE_STATE), ca.SX.sym("dtheta", 3), ca.SX.sym("dv", 3), ca.SX.sym("dt")
    return ca.Function("free_inertial_step", [x, dth, dv, dt], [free_inertial_step_expr(x, dth, dv, dt)])


@dataclasses.dataclass
class NavigationRun:
    """Position error of one free-inertial run, north and east (m), after each output time (s)."""

    label: str
    time: np.ndarray  # s since the start of navigation
    north_m: np.ndarray
    east_m: np.ndarray

    @property
    def horizontal_m(self) -> np.ndarray:
        """Horizontal position error, m."""
        return np.hypot(self.north_m, self.east_m)


def navigate_free(rec: Recording, params: np.ndarray, align_s: float, label: str, step_s: float = 0.1,
                  output_s: float = 1.0) -> NavigationRun:
    """Align on the first ``align_s`` and navigate the rest free-inertially; position error from the site.

    The base is static, so the increments are summed into ``step_s`` steps (exact for a body at rest:
    a noise-free recording with the true parameters stays within 1e-6 m over an hour).
    """
    dtheta, dv = compensated_increments(rec, params)
    n_align = int(round(align_s * rec.rate_hz))
    attitude = align(dtheta[:n_align], dv[:n_align], rec.dt)
    block = max(1, int(round(step_s * rec.rate_hz)))
    steps = (len(dtheta) - n_align) // block
    used = slice(n_align, n_align + steps * block)
    dtheta = dtheta[used].reshape(steps, block, 3).sum(axis=1)
    dv = dv[used].reshape(steps, block, 3).sum(axis=1)
    lat0, h0 = rec.site.latitude, rec.site.height
    x0 = np.concatenate([dcm_to_quat(attitude), np.zeros(3), [lat0, 0.0, h0], dtheta[0], dv[0]])
    chain = free_inertial_step().mapaccum("free_inertial", steps)
    every = max(1, int(round(output_s / (block * rec.dt))))
    states = np.asarray(chain(x0, dtheta.T, dv.T, block * rec.dt)).T[every - 1::every]
    decimate = every * block
    r_m, r_n = earth_radii(lat0)
    north = (states[:, 7] - lat0) * (r_m + h0)
    east = states[:, 8] * (r_n + h0) * np.cos(lat0)
    t = (np.arange(len(states)) + 1) * decimate * rec.dt
    return NavigationRun(label, t, north, east)
