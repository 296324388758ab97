"""Every rotation conversion, written once: rotation vectors, matrices, quaternions, the triad.

Attitude is the direction cosine matrix ``C_b^n`` whose columns are the body axes written in the
navigation frame; quaternions are ``(w, x, y, z)`` with ``q_b^n``.  Functions named ``*_expr``
build CasADi expressions (the strapdown step, the estimator's graph); the others take NumPy arrays.
Where both are needed, the formula exists once: both forms take one element-wise formula (the
quaternion's rotation matrix), or they differ on purpose (the CasADi rotation-vector quaternion is a
series whose derivative exists at zero; the NumPy one is exact for any angle).
"""

from __future__ import annotations

import casadi as ca
import numpy as np


def skew(v) -> np.ndarray:
    """Cross-product matrix: ``skew(a) @ b == np.cross(a, b)``."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotation_matrices(rotvec) -> np.ndarray:
    """Rotation matrices of rotation vectors (rad), vectorised: (..., 3) -> (..., 3, 3).

    Rodrigues' formula, with series near zero.  Active, right-hand rule: the matrix of
    ``pi/2 * z`` maps x onto y.
    """
    rotvec = np.asarray(rotvec, dtype=float)
    theta2 = np.sum(rotvec * rotvec, axis=-1)[..., None, None]
    small = theta2 < 1e-12
    theta = np.sqrt(np.where(small, 1.0, theta2))
    a = np.where(small, 1.0 - theta2 / 6.0, np.sin(theta) / theta)
    b = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(theta)) / np.where(small, 1.0, theta2))
    x, y, z = rotvec[..., 0], rotvec[..., 1], rotvec[..., 2]
    zero = np.zeros_like(x)
    k = np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)
    return np.eye(3) + a * k + b * (k @ k)


def rotation_matrix(axis, angle) -> np.ndarray:
    """Rotation matrix about ``axis`` (normalised here) by ``angle`` (rad).

    Vectorised over ``angle``: an array of shape (M,) gives shape (M, 3, 3).
    """
    axis = np.asarray(axis, dtype=float)
    angle = np.asarray(angle, dtype=float)
    return rotation_matrices(angle[..., None] * (axis / np.linalg.norm(axis)))


def dcm_to_quat(dcm) -> np.ndarray:
    """Unit quaternion (w, x, y, z), ``w >= 0``, of a rotation matrix (Shepperd's method)."""
    m = np.asarray(dcm, dtype=float)
    tr = np.trace(m)
    i = int(np.argmax([tr, m[0, 0], m[1, 1], m[2, 2]]))
    if i == 0:
        w = 0.5 * np.sqrt(1.0 + tr)
        q = [w, (m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w)]
    elif i == 1:
        x = 0.5 * np.sqrt(1.0 + 2 * m[0, 0] - tr)
        q = [(m[2, 1] - m[1, 2]) / (4 * x), x, (m[0, 1] + m[1, 0]) / (4 * x), (m[0, 2] + m[2, 0]) / (4 * x)]
    elif i == 2:
        y = 0.5 * np.sqrt(1.0 + 2 * m[1, 1] - tr)
        q = [(m[0, 2] - m[2, 0]) / (4 * y), (m[0, 1] + m[1, 0]) / (4 * y), y, (m[1, 2] + m[2, 1]) / (4 * y)]
    else:
        z = 0.5 * np.sqrt(1.0 + 2 * m[2, 2] - tr)
        q = [(m[1, 0] - m[0, 1]) / (4 * z), (m[0, 2] + m[2, 0]) / (4 * z), (m[1, 2] + m[2, 1]) / (4 * z), z]
    q = np.array(q)
    return q / np.linalg.norm(q) * (1.0 if q[0] >= 0 else -1.0)


def rotation_vector(dcm) -> np.ndarray:
    """Rotation vector (rad) of a rotation matrix, any angle up to pi (through the quaternion)."""
    q = dcm_to_quat(dcm)
    norm = np.linalg.norm(q[1:])
    if norm < 1e-15:
        return np.zeros(3)
    return 2.0 * np.arctan2(norm, q[0]) * q[1:] / norm


#: North-east-down to east-north-up (a permutation and a sign: its own inverse).
NED_TO_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def euler_to_enu(angles) -> np.ndarray:
    """Attitude matrices in ENU, ``(..., 3, 3)``, of roll, pitch, heading ``(..., 3)`` (rad): Z-Y-X Euler angles
    of a body (x forward, y right, z down) from north-east-down, ``C^ENU = T Rz(heading) Ry(pitch) Rx(roll)``."""
    angles = np.asarray(angles, dtype=float)
    roll, pitch, heading = angles[..., 0], angles[..., 1], angles[..., 2]
    cr, sr, cp, sp, ch, sh = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(heading), np.sin(heading)
    ned = np.stack([np.stack([ch * cp, ch * sp * sr - sh * cr, ch * sp * cr + sh * sr], -1),
                    np.stack([sh * cp, sh * sp * sr + ch * cr, sh * sp * cr - ch * sr], -1),
                    np.stack([-sp, cp * sr, cp * cr], -1)], -2)
    return NED_TO_ENU @ ned


def enu_to_euler(dcm) -> np.ndarray:
    """Roll, pitch, heading ``(..., 3)`` (rad) of attitude matrices in ENU: the inverse of :func:`euler_to_enu`."""
    ned = NED_TO_ENU @ np.asarray(dcm, dtype=float)
    roll = np.arctan2(ned[..., 2, 1], ned[..., 2, 2])
    pitch = -np.arcsin(np.clip(ned[..., 2, 0], -1.0, 1.0))
    heading = np.arctan2(ned[..., 1, 0], ned[..., 0, 0])
    return np.stack([roll, pitch, heading], -1)


def small_rotations(dcm, reference) -> np.ndarray:
    """Rotation vectors ``(..., 3)`` of ``dcm @ reference^T`` (rotations within about 90 deg): the vee of the
    antisymmetric part, stretched by ``asin``."""
    relative = np.asarray(dcm, dtype=float) @ np.swapaxes(np.asarray(reference, dtype=float), -1, -2)
    vee = 0.5 * np.stack([relative[..., 2, 1] - relative[..., 1, 2], relative[..., 0, 2] - relative[..., 2, 0],
                          relative[..., 1, 0] - relative[..., 0, 1]], -1)
    size = np.linalg.norm(vee, axis=-1, keepdims=True)
    stretch = np.where(size > 0, np.arcsin(np.minimum(size, 1.0)) / np.where(size > 0, size, 1.0), 1.0)
    return vee * stretch


# --------------------------------------------------------------------------- quaternions in CasADi
def quat_multiply_expr(a, b):
    """Hamilton product ``a * b`` of quaternions (w, x, y, z)."""
    aw, av = a[0], a[1:4]
    bw, bv = b[0], b[1:4]
    return ca.vertcat(aw * bw - ca.dot(av, bv), aw * bv + bw * av + ca.cross(av, bv))


def quat_from_rotvec_expr(phi):
    """Quaternion of a small rotation vector, by series (exact to 1e-16 for |phi| < 0.1 rad).

    The series avoids ``sqrt(phi . phi)``, whose derivative is undefined at zero.
    """
    x2 = ca.dot(phi, phi)
    c = 1 - x2 / 8 + x2**2 / 384 - x2**3 / 46080
    s = 0.5 - x2 / 48 + x2**2 / 3840 - x2**3 / 645120
    return ca.vertcat(c, s * phi)


def _dcm_rows(w, x, y, z) -> list[list]:
    """The nine entries of the direction cosine matrix of a unit quaternion, row by row (element-wise
    operations only, so that NumPy arrays and CasADi symbols take the same formula)."""
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]


def quat_to_dcm_expr(q):
    """Direction cosine matrix of a unit quaternion (w, x, y, z)."""
    return ca.vertcat(*[ca.horzcat(*row) for row in _dcm_rows(q[0], q[1], q[2], q[3])])


def quat_to_dcm(q) -> np.ndarray:
    """The formula of :func:`quat_to_dcm_expr` in NumPy, for one quaternion (4,) -> (3, 3) or many
    (..., 4) -> (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    rows = _dcm_rows(q[..., 0], q[..., 1], q[..., 2], q[..., 3])
    return np.stack([np.stack(row, -1) for row in rows], -2)


def quat_multiply(a, b) -> np.ndarray:
    """Hamilton product ``a * b`` of quaternions (w, x, y, z) in NumPy, batched over leading axes
    (:func:`quat_multiply_expr` in CasADi)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    return np.concatenate([aw * bw - np.sum(av * bv, -1, keepdims=True),
                           aw * bv + bw * av + np.cross(av, bv)], axis=-1)


def quat_from_rotvec(v) -> np.ndarray:
    """Quaternions (w, x, y, z) of rotation vectors of any size in NumPy, batched over leading axes
    (exact; :func:`quat_from_rotvec_expr` is the small-angle series for CasADi)."""
    v = np.asarray(v, dtype=float)
    angle = np.linalg.norm(v, axis=-1, keepdims=True)
    half = 0.5 * angle
    sinc = np.where(angle > 1e-12, np.sin(half) / np.where(angle > 1e-12, angle, 1.0), 0.5 - angle**2 / 48.0)
    return np.concatenate([np.cos(half), v * sinc], axis=-1)


# --------------------------------------------------------------------------- two-vector attitude
def triad(up_vector, second_vector):
    """Attitude ``C_b^n`` (ENU) from a body vector that points up and a second body vector.

    ``up = u / |u|``, ``east = (s x u) / |s x u|``, ``north = up x east``: with the mean specific force
    and the mean rate at rest this is the coarse analytic alignment of Kang et al. (2013, eq. 14),
    tilt from the accelerometers alone (physics pitfall 6).  NumPy arrays or CasADi symbols.
    """
    if isinstance(up_vector, (ca.SX, ca.MX)) or isinstance(second_vector, (ca.SX, ca.MX)):
        up = up_vector / ca.norm_2(up_vector)
        east = ca.cross(second_vector, up_vector)
        east = east / ca.norm_2(east)
        return ca.vertcat(east.T, ca.cross(up, east).T, up.T)
    up = np.asarray(up_vector, dtype=float) / np.linalg.norm(up_vector)
    east = np.cross(second_vector, up_vector)
    east = east / np.linalg.norm(east)
    return np.vstack([east, np.cross(up, east), up])
