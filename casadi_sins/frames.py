"""Frames, orientation letters, rotations and the Earth model.

Navigation frame n is local-level East-North-Up (ENU), fixed to the Earth at
the test site.  Attitude is the direction cosine matrix ``C_b^n`` whose columns
are the body axes x, y, z written in n.  An orientation is three letters, the
directions of body x, y, z (``"NUE"``: x North, y Up, z East).
"""

from __future__ import annotations

import numpy as np

#: Earth rotation rate (WGS-84), rad/s.
EARTH_RATE = 7.2921151467e-5
#: Standard gravity, m/s^2; defines the unit ``ug`` (1e-6 * G0) at the edges.
G0 = 9.80665

# WGS-84 ellipsoid and Somigliana normal gravity constants.
_WGS84_A = 6378137.0
_WGS84_F = 1.0 / 298.257223563
_WGS84_E2 = _WGS84_F * (2.0 - _WGS84_F)
_GAMMA_E = 9.7803253359
_SOMIGLIANA_K = 0.00193185265241
_WGS84_M = 0.00344978650684  # omega^2 a^2 b / GM

DIRECTIONS = {
    "E": np.array([1.0, 0.0, 0.0]),
    "W": np.array([-1.0, 0.0, 0.0]),
    "N": np.array([0.0, 1.0, 0.0]),
    "S": np.array([0.0, -1.0, 0.0]),
    "U": np.array([0.0, 0.0, 1.0]),
    "D": np.array([0.0, 0.0, -1.0]),
}

AXES = {"X": 0, "Y": 1, "Z": 2}


class OrientationError(ValueError):
    """An orientation or axis string that does not describe a valid frame."""


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix: ``skew(a) @ b == np.cross(a, b)``."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def orientation_to_dcm(letters: str) -> np.ndarray:
    """Attitude ``C_b^n`` (ENU) of an orientation given as three direction letters.

    Parameters
    ----------
    letters : str
        Directions of body x, y and z, each one of ``N S E W U D``,
        e.g. ``"NUE"``.

    Returns
    -------
    ndarray, shape (3, 3)
        Columns are the body axes in ENU.

    Raises
    ------
    OrientationError
        Unknown letters, or axes that do not form a right-handed frame.
    """
    if not isinstance(letters, str) or len(letters) != 3:
        raise OrientationError(f"orientation {letters!r} must be three letters of N S E W U D")
    unknown = [c for c in letters.upper() if c not in DIRECTIONS]
    if unknown:
        raise OrientationError(
            f"orientation {letters!r} has unknown letter(s) {''.join(unknown)!r}; use N S E W U D"
        )
    dcm = np.column_stack([DIRECTIONS[c] for c in letters.upper()])
    det = np.linalg.det(dcm)
    if abs(det - 1.0) > 1e-9:
        kind = "left-handed" if abs(det + 1.0) < 1e-9 else "degenerate (repeated axis)"
        raise OrientationError(f"orientation {letters!r} is not a right-handed frame ({kind})")
    return dcm


def dcm_to_orientation(dcm: np.ndarray, tol_deg: float = 20.0) -> str:
    """Nearest orientation letters of an attitude; error if an axis is off by more than ``tol_deg``."""
    letters = []
    for col in np.asarray(dcm).T:
        best = max(DIRECTIONS, key=lambda k: float(DIRECTIONS[k] @ col))
        if DIRECTIONS[best] @ col < np.cos(np.radians(tol_deg)):
            raise OrientationError("attitude is not near any orientation of the letters N S E W U D")
        letters.append(best)
    return "".join(letters)


def parse_axis(axis: str) -> np.ndarray:
    """Unit vector in body coordinates of an axis string ``"+X"``, ``"-Z"``, ``"Y"``."""
    if not isinstance(axis, str):
        raise OrientationError(f"rotation axis {axis!r} must be a string such as '+Z'")
    text = axis.strip().upper()
    sign = -1.0 if text.startswith("-") else 1.0
    name = text.lstrip("+-")
    if name not in AXES or len(text) - len(name) > 1:
        raise OrientationError(f"rotation axis {axis!r} is not one of +X -X +Y -Y +Z -Z")
    v = np.zeros(3)
    v[AXES[name]] = sign
    return v


def rotation_matrix(axis: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """Rodrigues rotation matrix about ``axis`` (normalised here) by ``angle`` (rad).

    Vectorised over ``angle``: an array of shape (M,) gives shape (M, 3, 3).
    Active, right-hand rule: ``rotation_matrix(z, pi/2) @ x == y``.
    """
    axis = np.asarray(axis, dtype=float)
    u = axis / np.linalg.norm(axis)
    k = skew(u)
    angle = np.asarray(angle, dtype=float)
    s = np.sin(angle)[..., None, None]
    c = (1.0 - np.cos(angle))[..., None, None]
    return np.eye(3) + s * k + c * (k @ k)


def rotate_body(dcm: np.ndarray, axis: str | np.ndarray, angle_rad: float) -> np.ndarray:
    """Attitude after turning the body about its own ``axis`` by ``angle_rad``: ``C R(axis, angle)``."""
    vec = parse_axis(axis) if isinstance(axis, str) else axis
    return np.asarray(dcm) @ rotation_matrix(vec, angle_rad)


def small_rotation(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (rad)."""
    rotvec = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(rotvec)
    if angle == 0.0:
        return np.eye(3)
    return rotation_matrix(rotvec, angle)


def rotation_matrices(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrices of rotation vectors, vectorised: (..., 3) -> (..., 3, 3) (Rodrigues, series near zero)."""
    theta2 = np.sum(rotvec * rotvec, axis=-1)[..., None, None]
    small = theta2 < 1e-12
    theta = np.sqrt(np.where(small, 1.0, theta2))
    a = np.where(small, 1.0 - theta2 / 6.0, np.sin(theta) / theta)
    b = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(theta)) / np.where(small, 1.0, theta2))
    x, y, z = rotvec[..., 0], rotvec[..., 1], rotvec[..., 2]
    zero = np.zeros_like(x)
    k = np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)
    return np.eye(3) + a * k + b * (k @ k)


def rotation_vector(dcm: np.ndarray) -> np.ndarray:
    """Rotation vector (rad) of a rotation matrix (inverse of :func:`small_rotation`, angle < pi)."""
    dcm = np.asarray(dcm)
    cos_a = np.clip((np.trace(dcm) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos_a)
    w = np.array([dcm[2, 1] - dcm[1, 2], dcm[0, 2] - dcm[2, 0], dcm[1, 0] - dcm[0, 1]]) / 2.0
    if angle < 1e-8:
        return w
    return w * angle / np.sin(angle)


def earth_rate_enu(latitude_rad: float) -> np.ndarray:
    """Earth rotation rate in the ENU frame, rad/s."""
    return EARTH_RATE * np.array([0.0, np.cos(latitude_rad), np.sin(latitude_rad)])


def _math(*values):
    """CasADi for symbolic arguments, NumPy otherwise: the Earth model is written once for both."""
    import casadi as ca

    return ca if any(isinstance(v, (ca.SX, ca.MX)) for v in values) else np


def normal_gravity(latitude_rad, height_m=0.0):
    """WGS-84 normal gravity magnitude (Somigliana, second-order height correction), m/s^2.

    Numbers give a float; CasADi symbols give an expression.
    """
    xp = _math(latitude_rad, height_m)
    s2 = xp.sin(latitude_rad) ** 2
    g0 = _GAMMA_E * (1.0 + _SOMIGLIANA_K * s2) / xp.sqrt(1.0 - _WGS84_E2 * s2)
    a = _WGS84_A
    g = g0 * (1.0 - 2.0 / a * (1.0 + _WGS84_F + _WGS84_M - 2.0 * _WGS84_F * s2) * height_m
              + 3.0 * height_m**2 / a**2)
    return g if xp is not np else float(g)


def earth_radii(latitude_rad):
    """WGS-84 meridian and prime-vertical radii of curvature ``(R_M, R_N)``, m (numbers or CasADi)."""
    xp = _math(latitude_rad)
    w2 = 1.0 - _WGS84_E2 * xp.sin(latitude_rad) ** 2
    r_n = _WGS84_A / xp.sqrt(w2)
    return r_n * (1.0 - _WGS84_E2) / w2, r_n
