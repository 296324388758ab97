"""Error-state model of free-inertial navigation on a static base with a turning IMU.

The error state (31) is the navigation error followed by the constant sensor errors::

    x = (phi_E, phi_N, phi_U, dv_E, dv_N, dL, dlon,    the 21 parameter errors,    dK*_x, dK*_y, dK*_z)

with the 21 in the package's order (:data:`casadi_sins.model.registry.NAMES`) and the convention of
Kang et al. 2013, eqs. 5-12 (:mod:`casadi_sins.nav.errormodel`): the compensated outputs err by
``d_w = T_g w + eps`` and ``d_f = T_a f + Delta`` (``t_ii`` relative scale errors, ``t_ij``
misalignments, ``T_a`` lower triangular).  The last three are the gyro scale-factor asymmetry (Guan et
al. 2023, eq. 33): the scale error differs by ``+-dK*`` between positive and negative rates,
``d_w_i += dK*_i |w_i|``.

The dynamics are those of :mod:`casadi_sins.nav.errorstate` (as the budget's) with the IMU attitude ``C(t) = C_b^n`` and
the body rate ``w(t) = C(t)^T w_ie + w_table(t)`` now functions of time (Guan et al. 2023, eqs. 1-8;
the phi-angle model of Yu and Ruan 2014, eq. 1)::

    phi'  = -w_ie x phi + d(w_ie)/dL dL + d(w_en)/dv dv - C(t) (d_w(t) + n_g)
    dv_h' = (f^n x phi)_h - (2 w_ie x dv)_h + (C(t) (d_f(t) + n_a))_h
    dL'   = dv_N / (R_M + h),      dlon' = dv_E / ((R_N + h) cos L)

with ``f^n = (0, 0, g)``, ``f^b(t) = C(t)^T f^n`` (the IMU turns about its centre) and white noise
``n_g``, ``n_a`` of power spectral density ARW^2, VRW^2.  The vertical channel is held at the known
height (as marine and land systems do with a depth or height reference): no vertical velocity or
height error states, so the unstable vertical loop does not enter.  The site is
:class:`casadi_sins.core.earth.Site` (WGS-84 normal gravity unless it gives one).
"""

from __future__ import annotations

import numpy as np

from ...core import units
from ...core.earth import Site
from ...core.errors import InputError
from ...model import registry
from ...nav import errorstate
from ...nav.errormodel import input_sensitivity

NAV_NAMES = errorstate.NAV_NAMES
#: The 21 parameter errors, in the package's order.
PARAM_NAMES = registry.NAMES
ASYM_NAMES = ("gyro_asymmetry_x", "gyro_asymmetry_y", "gyro_asymmetry_z")
STATE_NAMES = NAV_NAMES + PARAM_NAMES + ASYM_NAMES
N_NAV, N_STATE = len(NAV_NAMES), len(STATE_NAMES)
INDEX = {name: i for i, name in enumerate(STATE_NAMES)}

PHI, DV, POS = errorstate.PHI, errorstate.DV, errorstate.POS
SENSOR = slice(N_NAV, N_STATE)  # the constant sensor-error states


def _shift(span: slice) -> slice:
    return slice(span.start + N_NAV, span.stop + N_NAV)


ACCEL_BIAS, ACCEL_SCALE, ACCEL_MISALIGN = (_shift(registry.ACCEL_BIAS), _shift(registry.ACCEL_SCALE),
                                           _shift(registry.ACCEL_MISALIGN))
GYRO_BIAS, GYRO_SCALE, GYRO_MISALIGN = (_shift(registry.GYRO_BIAS), _shift(registry.GYRO_SCALE),
                                        _shift(registry.GYRO_MISALIGN))
GYRO_ASYM = slice(INDEX["gyro_asymmetry_x"], N_STATE)
#: (row, column) of each misalignment in T_g and T_a (T_a lower triangular).
GYRO_MISALIGN_ENTRIES = registry.GYRO_MISALIGN_ENTRIES
ACCEL_MISALIGN_ENTRIES = registry.ACCEL_MISALIGN_ENTRIES
#: The longitude error (sec L) and the ENU frame degenerate near the pole.
MAX_LATITUDE_DEG = 89.0


#: The highest (and deepest) site the model takes, m: normal gravity and the Earth's radius of curvature hold there.
MAX_HEIGHT_M = 1e5


def check_site(site: Site) -> Site:
    """The site, if the model can take it: finite, and more than :data:`MAX_LATITUDE_DEG` from a pole.

    Raises
    ------
    InputError
        Naming the value at fault.
    """
    if not np.isfinite(site.latitude) or not np.isfinite(site.height):
        raise InputError(None, f"latitude and height must be finite (got {site.latitude}, {site.height})")
    if not abs(site.height) <= MAX_HEIGHT_M:
        raise InputError(None, f"height {site.height:g} m is beyond {MAX_HEIGHT_M:g} m of the ground: not a site of an "
                         "inertial navigator")
    if abs(site.latitude) >= MAX_LATITUDE_DEG * units.DEG:
        raise InputError(None, f"|latitude| {abs(site.latitude) / units.DEG:g} deg >= {MAX_LATITUDE_DEG:g} deg: "
                         "the longitude error (sec L) and the ENU frame degenerate near the pole")
    return site


def to_metres(site: Site) -> np.ndarray:
    """Metres per radian of (latitude, longitude) error: north and east."""
    return errorstate.position_metres(site.latitude, site.height)


def navigation_block(site: Site) -> np.ndarray:
    """The constant part of ``F``: the navigation errors among themselves (:mod:`casadi_sins.nav.errorstate`)."""
    return errorstate.navigation_block(site.latitude, site.height, site.g, N_STATE)


def gyro_sensitivity(w_body: np.ndarray) -> np.ndarray:
    """``d(d_w)/d(sensor states)`` (3, 24) at body rate ``w_body``: the 21's
    (:func:`casadi_sins.nav.errormodel.input_sensitivity`, eqs. 5-12), then the asymmetry's ``diag(|w|)``."""
    return np.hstack([input_sensitivity(w_body[None], 1.0, "gyro")[0], np.diag(np.abs(w_body))])


def accel_sensitivity(f_body: np.ndarray) -> np.ndarray:
    """``d(d_f)/d(sensor states)`` (3, 24) at specific force ``f_body``: the 21's
    (:func:`casadi_sins.nav.errormodel.input_sensitivity`), none of the asymmetry."""
    return np.hstack([input_sensitivity(f_body[None], 1.0, "accel")[0], np.zeros((3, len(ASYM_NAMES)))])


def error_matrix(nav: np.ndarray, site: Site, attitude: np.ndarray, table_rate: np.ndarray) -> np.ndarray:
    """``F`` at one instant: ``nav`` (from :func:`navigation_block`) plus the sensor-error inputs.

    ``table_rate`` is the IMU's rate relative to the base, in the body (rad/s).
    """
    w_body = attitude.T @ site.earth_rate + table_rate
    f_body = attitude.T @ np.array([0.0, 0.0, site.g])
    return errorstate.with_sensor_inputs(nav, attitude @ gyro_sensitivity(w_body), attitude @ accel_sensitivity(f_body))


def noise_inputs(attitude: np.ndarray, gyro_arw: np.ndarray, accel_vrw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``G Q G^T`` (31, 31) of the gyro and of the accelerometer white noise (PSD ARW^2, VRW^2 per axis)."""
    s_g = np.zeros((N_STATE, N_STATE))
    s_a = np.zeros((N_STATE, N_STATE))
    s_g[PHI, PHI] = attitude @ np.diag(np.asarray(gyro_arw) ** 2) @ attitude.T
    s_a[DV, DV] = (attitude @ np.diag(np.asarray(accel_vrw) ** 2) @ attitude.T)[:2, :2]
    return s_g, s_a


def alignment_map(site: Site, attitude: np.ndarray) -> np.ndarray:
    """``d(phi_0)/d(sensor states)`` (3, 24): the attitude error of a static alignment at ``attitude``.

    The alignment levels on the measured specific force and finds north from the measured Earth rate,
    so to first order it leaves the computed horizontal specific force and east Earth rate at zero::

        phi_E = -df_N / g,    phi_N = df_E / g,    phi_U = tan(L) df_E / g - dw_E / w_ie,N

    with ``df^n = C d_f``, ``dw^n = C d_w`` of the errors at rest: the coarse alignment of Kang et al.
    2013 (eq. 14) linearised (eq. 15) in closed form, which the tests hold against the package's
    :func:`casadi_sins.nav.errormodel.alignment_sensitivity`.  Through CasADi
    (:func:`casadi_sins.nav.alignment.alignment_error`) it agrees to 1e-15 relative, but an aligned run's
    ratios to strapdown divide by strapdown contributions that the alignment cancels to rounding, and
    those ratios would change.
    """
    w_body = attitude.T @ site.earth_rate
    f_body = attitude.T @ np.array([0.0, 0.0, site.g])
    df = attitude @ accel_sensitivity(f_body)
    dw = attitude @ gyro_sensitivity(w_body)
    g, w_n = site.g, site.earth_rate[1]
    return np.stack([-df[1] / g, df[0] / g, np.tan(site.latitude) * df[0] / g - dw[0] / w_n])
