"""Navigation error state of free-inertial navigation on a static base: the (phi, dv, position) block.

The error state starts with the navigation errors (ENU, vertical channel held at the known height)::

    x_nav = (phi_E, phi_N, phi_U, dv_E, dv_N, dL, dlon)

with ``C_hat = (I - [phi x]) C`` (Kang et al. 2013, eqs. 13-21, extended by the position errors and
Coriolis; the phi-angle model of Yu and Ruan 2014, eq. 1; Guan et al. 2023, eqs. 1-8)::

    phi'  = -w_ie x phi + d(w_ie)/dL dL + d(w_en)/dv dv - C d_w
    dv_h' = (f^n x phi)_h - (2 w_ie x dv)_h + (C d_f)_h
    dL'   = dv_N / (R_M + h),      dlon' = dv_E / ((R_N + h) cos L)

with ``f^n = (0, 0, g)``.  The sensor errors ``d_w``, ``d_f`` are linear in constant error states that
follow the navigation ones: :func:`navigation_block` fills the navigation errors among themselves and
:func:`with_sensor_inputs` the columns of those states.  The error budget
(:mod:`casadi_sins.studies.budget`) and the rotation-modulation study (:mod:`casadi_sins.studies.modulation`)
both build their ``F`` from here.
"""

from __future__ import annotations

import numpy as np

from ..core.earth import EARTH_RATE, earth_radii
from ..core.rotations import skew

NAV_NAMES = ("phi_E", "phi_N", "phi_U", "dv_E", "dv_N", "dlat", "dlon")
N_NAV = len(NAV_NAMES)
PHI, DV, POS = slice(0, 3), slice(3, 5), slice(5, 7)


def navigation_block(latitude: float, height: float, gravity: float, n_state: int = N_NAV) -> np.ndarray:
    """``F`` (n_state, n_state) with only the navigation errors among themselves filled.

    Parameters
    ----------
    latitude : float
        rad.
    height : float
        m.
    gravity : float
        Magnitude of gravity at the site, m/s^2.
    n_state : int
        Size of the whole error state (the navigation errors, then the sensor-error states).
    """
    sl, cl = np.sin(latitude), np.cos(latitude)
    r_m, r_n = earth_radii(latitude)
    r_m, r_n = r_m + height, r_n + height
    w_ie = EARTH_RATE * np.array([0.0, cl, sl])
    f = np.zeros((n_state, n_state))
    f[PHI, PHI] = -skew(w_ie)
    f[PHI, 5] = EARTH_RATE * np.array([0.0, -sl, cl])  # d(w_ie)/dL
    f[PHI, DV] = np.array([[0.0, -1.0 / r_m], [1.0 / r_n, 0.0], [sl / cl / r_n, 0.0]])  # d(w_en)/d(v_E, v_N)
    f[DV, PHI] = skew(np.array([0.0, 0.0, gravity]))[:2]  # f^n x phi
    f[DV, DV] = -skew(2.0 * w_ie)[:2, :2]  # Coriolis
    f[5, 4] = 1.0 / r_m
    f[6, 3] = 1.0 / (r_n * cl)
    return f


def position_metres(latitude: float, height: float) -> np.ndarray:
    """Metres per radian of the (latitude, longitude) errors at the site: north and east, ``(R_M + h,
    (R_N + h) cos L)``."""
    r_m, r_n = earth_radii(latitude)
    return np.array([r_m + height, (r_n + height) * np.cos(latitude)])


def with_sensor_inputs(nav: np.ndarray, gyro_input: np.ndarray, accel_input: np.ndarray) -> np.ndarray:
    """``F``: ``nav`` (:func:`navigation_block`) plus the sensor-error columns.

    ``gyro_input`` and ``accel_input`` are ``d(C d_w)/dx`` and ``d(C d_f)/dx`` (3, states after the
    navigation errors), navigation frame.
    """
    f = nav.copy()
    f[PHI, N_NAV:] = -gyro_input
    f[DV, N_NAV:] = accel_input[:2]
    return f
