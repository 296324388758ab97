"""Navigation error state of free-inertial navigation on a static base: the (phi, dv, position) block.

The error state starts with the navigation errors (ENU, vertical channel held at the known height)::

    x_nav = (phi_E, phi_N, phi_U, dv_E, dv_N, dL, dlon)

with ``C_hat = (I - [phi x]) C`` (Kang et al. 2013, eqs. 13-21, extended by the position errors and
Coriolis; the phi-angle model of Yu and Ruan 2014, eq. 1; Guan et al. 2023, eqs. 1-8)::

    phi'  = -w_ie x phi + d(w_ie)/dL dL + d(w_en)/dv dv - C d_w
    dv_h' = (f^n x phi)_h - (2 w_ie x dv)_h + (C d_f)_h
    dL'   = dv_N / (R_M + h),      dlon' = dv_E / ((R_N + h) cos L)

with ``f^n = (0, 0, g)``.  The sensor errors ``d_w``, ``d_f`` are linear in constant error states that
follow the navigation ones, the errors of the parameters ``names`` (the 21, then any extra groups): their
columns are :func:`nav.errorinputs.error_columns`.  :func:`navigation_block` fills the navigation errors
among themselves and :func:`with_sensor_inputs` the columns of the sensor errors; :class:`ErrorModel` is
the whole state of a site and a parameter model, with the IMU at any attitude and turning at any rate on
the static base (Guan et al. 2023, eqs. 1-8).  The error budget (:mod:`casadi_sins.studies.budget`), the
rotation-modulation study (:mod:`casadi_sins.studies.modulation`) and the schedule design all propagate it
(:mod:`nav.propagation`).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ..core.earth import EARTH_RATE, Site, earth_radii
from ..core.rotations import skew
from ..model.registry import GROUPS, NAMES
from .alignment import alignment_error
from .errorinputs import body_motion, error_columns

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


@dataclasses.dataclass(frozen=True)
class ErrorModel:
    """The error state ``(phi_E, phi_N, phi_U, dv_E, dv_N, dlat, dlon, the parameters' errors)`` of free-inertial
    navigation at a site, with the dynamics of an IMU at any attitude, turning or not, on the static base.

    Attributes
    ----------
    site : Site
    names : tuple of str
        The parameters whose errors follow the navigation errors (the 21 first, then any extra groups).
    """

    site: Site
    names: tuple[str, ...] = NAMES

    @property
    def state_names(self) -> tuple[str, ...]:
        """Every state's name: :data:`NAV_NAMES`, then ``names``."""
        return NAV_NAMES + tuple(self.names)

    @property
    def n_state(self) -> int:
        """Size of the state."""
        return N_NAV + len(self.names)

    @property
    def sensor(self) -> slice:
        """The states of the parameters' errors."""
        return slice(N_NAV, self.n_state)

    def states(self, names) -> list[int]:
        """The states of the given parameters (in their order; ``ValueError`` for one not in the model)."""
        return [N_NAV + self.names.index(n) for n in names]

    def group_states(self, key: str) -> list[int]:
        """The states of a registry group's parameters present in the model (:data:`model.registry.GROUPS`)."""
        return [N_NAV + i for i, n in enumerate(self.names) if n in GROUPS[key].names]

    @functools.cached_property
    def navigation(self) -> np.ndarray:
        """``F`` with only the navigation errors among themselves filled (:func:`navigation_block`)."""
        return navigation_block(self.site.latitude, self.site.height, self.site.g, self.n_state)

    def motion(self, attitude: np.ndarray, table_rate=None):
        """``(w, f, w_rest)`` in the body at attitude(s) ``C_b^n`` (:func:`nav.errorinputs.body_motion`)."""
        return body_motion(attitude, self.site.earth_rate, self.site.g, table_rate)

    def inputs(self, attitude: np.ndarray, table_rate=None) -> tuple[np.ndarray, np.ndarray]:
        """``(C d(d_w)/dx, C d(d_f)/dx)`` (3, parameters) at attitude ``C_b^n`` turning at ``table_rate`` (body)."""
        gyro, accel = error_columns(self.names, *self.motion(attitude, table_rate))
        return attitude @ gyro, attitude @ accel

    def matrix(self, attitude: np.ndarray, table_rate=None) -> np.ndarray:
        """``F`` at attitude ``C_b^n`` with the table turning at ``table_rate`` (body, rad/s; default still)."""
        return with_sensor_inputs(self.navigation, *self.inputs(attitude, table_rate))

    def noise(self, attitude: np.ndarray, gyro_arw, accel_vrw) -> tuple[np.ndarray, np.ndarray]:
        """``G Q G^T`` of the gyro and of the accelerometer white noise at attitude ``C_b^n`` (PSD ARW^2 and
        VRW^2 per body axis, rad^2/s and m^2/s^3)."""
        s_g = np.zeros((self.n_state, self.n_state))
        s_a = np.zeros((self.n_state, self.n_state))
        s_g[PHI, PHI] = attitude @ np.diag(np.broadcast_to(np.asarray(gyro_arw, dtype=float) ** 2, 3)) @ attitude.T
        s_a[DV, DV] = (attitude @ np.diag(np.broadcast_to(np.asarray(accel_vrw, dtype=float) ** 2, 3))
                       @ attitude.T)[:2, :2]
        return s_g, s_a

    def alignment_map(self, attitude: np.ndarray) -> np.ndarray:
        """``d(phi_0)/dx`` (3, parameters): the attitude error of the coarse alignment (Kang et al. 2013, eq. 14)
        of a still unit at ``C_b^n``, linearised (eq. 15, :func:`nav.alignment.alignment_error`), for errors of
        every parameter: the means it levels and finds north on err by the sensor-error columns at rest."""
        rate, force, _ = self.motion(attitude)
        gyro, accel = error_columns(self.names, rate, force)
        return alignment_error(force, rate, np.vstack([accel, gyro]))

    def alignment_noise_map(self, attitude: np.ndarray) -> np.ndarray:
        """``d(phi_0)/d(mean f, mean w)`` (3, 6): the alignment's attitude error for errors of its means (its
        noise), at ``C_b^n``."""
        rate, force, _ = self.motion(attitude)
        return alignment_error(force, rate, np.eye(6))

    def to_metres(self) -> np.ndarray:
        """Metres per radian of the (latitude, longitude) errors: north and east (:func:`position_metres`)."""
        return position_metres(self.site.latitude, self.site.height)
