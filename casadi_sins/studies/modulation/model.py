"""The error model of the modulation study: the package's one navigation error state, at a site it can take.

The error state is that of :class:`casadi_sins.nav.errorstate.ErrorModel`: the navigation errors followed by
the errors of the registry's parameters the sources hold (:mod:`casadi_sins.model.registry`)::

    x = (phi_E, phi_N, phi_U, dv_E, dv_N, dL, dlon,    the 21 parameter errors,    any extra groups' errors)

with the 21 in the package's order and the convention of Kang et al. 2013, eqs. 5-12: the compensated
outputs err by ``d_w = T_g w + eps`` and ``d_f = T_a f + Delta`` (``t_ii`` relative scale errors, ``t_ij``
misalignments, ``T_a`` lower triangular), and each extra group by its own term
(:mod:`casadi_sins.nav.errorinputs`), e.g. the gyro scale asymmetry ``gyro_scale_asym_*`` (Guan et al. 2023,
eq. 33: ``d_w_i += dK*_i |w_i|``) and the gyro g-sensitivity (``d_w += G f``).

The dynamics (:meth:`ErrorModel.matrix`) are those of the static budget with the IMU attitude ``C(t) = C_b^n``
and the body rate ``w(t) = C(t)^T w_ie + w_table(t)`` functions of time (Guan et al. 2023, eqs. 1-8; the
phi-angle model of Yu and Ruan 2014, eq. 1)::

    phi'  = -w_ie x phi + d(w_ie)/dL dL + d(w_en)/dv dv - C(t) (d_w(t) + n_g)
    dv_h' = (f^n x phi)_h - (2 w_ie x dv)_h + (C(t) (d_f(t) + n_a))_h
    dL'   = dv_N / (R_M + h),      dlon' = dv_E / ((R_N + h) cos L)

with ``f^n = (0, 0, g)``, ``f^b(t) = C(t)^T f^n`` (the IMU turns about its centre) and white noise ``n_g``,
``n_a`` of power spectral density ARW^2, VRW^2.  The vertical channel is held at the known height (as marine
and land systems do with a depth or height reference): no vertical velocity or height error states, so the
unstable vertical loop does not enter.  The site is :class:`casadi_sins.core.earth.Site` (WGS-84 normal
gravity unless it gives one).
"""

from __future__ import annotations

import numpy as np

from ...core import units
from ...core.earth import Site
from ...core.errors import InputError
from ...model import registry
from ...nav.errorstate import DV, N_NAV, NAV_NAMES, PHI, POS, ErrorModel

__all__ = ["DV", "N_NAV", "NAV_NAMES", "PHI", "POS", "ErrorModel", "SHEET_NAMES", "MAX_LATITUDE_DEG", "check_site",
           "INDEX", "ACCEL_BIAS", "ACCEL_SCALE", "ACCEL_MISALIGN", "GYRO_BIAS", "GYRO_SCALE", "GYRO_MISALIGN"]

#: The parameters an error sheet gives: the 21 and the gyro scale asymmetry.
SHEET_NAMES = registry.model_names(("gyro_asym",))
#: The states of the navigation errors and of the 21, the same in every model (the 21 follow the navigation errors).
INDEX = {name: i for i, name in enumerate(NAV_NAMES + registry.NAMES)}


def _shift(span: slice) -> slice:
    return slice(span.start + N_NAV, span.stop + N_NAV)


ACCEL_BIAS, ACCEL_SCALE, ACCEL_MISALIGN = (_shift(registry.ACCEL_BIAS), _shift(registry.ACCEL_SCALE),
                                           _shift(registry.ACCEL_MISALIGN))
GYRO_BIAS, GYRO_SCALE, GYRO_MISALIGN = (_shift(registry.GYRO_BIAS), _shift(registry.GYRO_SCALE),
                                        _shift(registry.GYRO_MISALIGN))
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
