"""The Earth at the test site: rotation rate, WGS-84 normal gravity and radii, the site itself.

Navigation frame n is local-level East-North-Up (ENU), fixed to the Earth at the test site.
Every function takes NumPy numbers or CasADi symbols: the Earth model is written once for both.
"""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np

#: Earth rotation rate (WGS-84), rad/s.
EARTH_RATE = 7.2921151467e-5
#: Standard gravity, m/s^2; defines the unit ``ug`` (1e-6 * G0) at the edges.
G0 = 9.80665

# WGS-84 ellipsoid and Somigliana normal gravity constants.
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
_GAMMA_E = 9.7803253359
_SOMIGLIANA_K = 0.00193185265241
_WGS84_M = 0.00344978650684  # omega^2 a^2 b / GM


def _math(*values):
    """CasADi for symbolic arguments, NumPy otherwise."""
    return ca if any(isinstance(v, (ca.SX, ca.MX)) for v in values) else np


def earth_rate_enu(latitude_rad):
    """Earth rotation rate in the ENU frame, rad/s (NumPy)."""
    return EARTH_RATE * np.array([0.0, np.cos(latitude_rad), np.sin(latitude_rad)])


def normal_gravity(latitude_rad, height_m=0.0):
    """WGS-84 normal gravity magnitude (Somigliana, second-order height correction), m/s^2.

    Parameters
    ----------
    latitude_rad, height_m : float or CasADi symbol

    Returns
    -------
    float or CasADi expression
    """
    xp = _math(latitude_rad, height_m)
    s2 = xp.sin(latitude_rad) ** 2
    g0 = _GAMMA_E * (1.0 + _SOMIGLIANA_K * s2) / xp.sqrt(1.0 - WGS84_E2 * s2)
    a = WGS84_A
    g = g0 * (1.0 - 2.0 / a * (1.0 + WGS84_F + _WGS84_M - 2.0 * WGS84_F * s2) * height_m
              + 3.0 * height_m**2 / a**2)
    return g if xp is not np else float(g)


def earth_radii(latitude_rad):
    """WGS-84 meridian and prime-vertical radii of curvature ``(R_M, R_N)``, m (numbers or CasADi)."""
    xp = _math(latitude_rad)
    w2 = 1.0 - WGS84_E2 * xp.sin(latitude_rad) ** 2
    r_n = WGS84_A / xp.sqrt(w2)
    return r_n * (1.0 - WGS84_E2) / w2, r_n


@dataclasses.dataclass(frozen=True)
class Site:
    """Test site: latitude (rad), height (m) and the gravity magnitude in use (m/s^2).

    ``gravity`` is the value a recording gives; ``None`` means WGS-84 normal gravity at the
    latitude and height (physics pitfall 1: a wrong g is a common accelerometer scale error).
    """

    latitude: float
    height: float = 0.0
    gravity: float | None = None

    @property
    def g(self) -> float:
        """The gravity magnitude in use, m/s^2."""
        return self.gravity if self.gravity is not None else normal_gravity(self.latitude, self.height)

    @property
    def earth_rate(self) -> np.ndarray:
        """``w_ie`` in ENU, rad/s."""
        return earth_rate_enu(self.latitude)
