"""Strapdown navigation on a static base: the one step, the alignment, navigation.

The navigation frame is ENU at the test site, fixed to the Earth; the base does
not move, so the transport rate and Coriolis terms vanish (spec, section 2)
and the n frame turns with the Earth rate only.  One step from sample
``k-1`` to ``k`` (quaternion ``q = q_b^n``, velocity ``v``)::

    phi_k   = dtheta_k + dtheta_{k-1} x dtheta_k / 12                 (coning)
    dv_rot  = dtheta_k x dv_k / 2 + dtheta_k x (dtheta_k x dv_k) / 6  (rotation, 1st + 2nd order)
    dv_scul = (dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k) / 12        (sculling)
    v_k     = v_{k-1} + (I - [w_ie dt x]/2) C(q_{k-1}) (dv_k + dv_rot + dv_scul) + g^n dt
    q_k     = q(-w_ie dt) * q_{k-1} * q(phi_k)

Without the second-order rotation term a 90 deg rotation at 14 deg/s peak
leaves a velocity step of (h^2 g / 6) int w^2 dt = 5e-5 m/s along gravity;
with it, the step is exact to O(h^3) for rotation about a fixed axis.  The
half-step n-frame rotation in the velocity update puts the Earth-rate
correction at the middle of the interval (physics pitfall 4).  The step is a
CasADi ``Function``: chained with ``mapaccum`` it is the numeric navigation
here, and the same object is the symbolic graph of the estimator.
"""

from __future__ import annotations

import dataclasses
import functools

import casadi as ca
import numpy as np

from . import parameters as P
from .recording import Recording

STATE_SIZE = 13  # q (4: w, x, y, z), v (3), previous dtheta (3), previous dv (3)
Q, V, PREV_DTHETA, PREV_DV = slice(0, 4), slice(4, 7), slice(7, 10), slice(10, 13)


# --------------------------------------------------------------------------- quaternion algebra (CasADi)
def quat_multiply(a, b):
    """Hamilton product ``a * b`` of quaternions (w, x, y, z)."""
    aw, av = a[0], a[1:4]
    bw, bv = b[0], b[1:4]
    return ca.vertcat(aw * bw - ca.dot(av, bv), aw * bv + bw * av + ca.cross(av, bv))


def quat_from_rotvec(phi):
    """Quaternion of a small rotation vector, by series (exact to 1e-16 for |phi| < 0.1 rad).

    The series avoids ``sqrt(phi . phi)``, whose derivative is undefined at zero.
    """
    x2 = ca.dot(phi, phi)
    c = 1 - x2 / 8 + x2**2 / 384 - x2**3 / 46080
    s = 0.5 - x2 / 48 + x2**2 / 3840 - x2**3 / 645120
    return ca.vertcat(c, s * phi)


def quat_to_dcm(q):
    """Direction cosine matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return ca.vertcat(
        ca.horzcat(1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        ca.horzcat(2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        ca.horzcat(2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )


def dcm_to_quat(dcm: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (NumPy, Shepperd's method)."""
    m = np.asarray(dcm, dtype=float)
    tr = np.trace(m)
    cands = np.array([tr, m[0, 0], m[1, 1], m[2, 2]])
    i = int(np.argmax(cands))
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


def quat_to_dcm_np(q: np.ndarray) -> np.ndarray:
    """NumPy evaluation of :func:`quat_to_dcm`."""
    return np.asarray(ca.DM(quat_to_dcm(ca.DM(np.asarray(q, dtype=float)))))


# --------------------------------------------------------------------------- the step
def corrected_increments(dtheta, dv, dtheta_prev, dv_prev):
    """Rotation vector and body velocity increment of one step: coning, rotation (1st and 2nd order) and
    sculling corrections from the current and previous compensated increments."""
    phi = dtheta + ca.cross(dtheta_prev, dtheta) / 12
    rotation = ca.cross(dtheta, dv) / 2 + ca.cross(dtheta, ca.cross(dtheta, dv)) / 6
    dv_body = dv + rotation + (ca.cross(dtheta_prev, dv) + ca.cross(dv_prev, dtheta)) / 12
    return phi, dv_body


def attitude_update(q, phi, nav_rate_dt):
    """``q_k = q(-w_in dt) * q_{k-1} * q(phi)``, normalised."""
    q_next = quat_multiply(quat_multiply(quat_from_rotvec(-nav_rate_dt), q), quat_from_rotvec(phi))
    return q_next / ca.norm_2(q_next)


def specific_force_increment(q, dv_body, nav_rate_dt):
    """``(I - [w_in dt x]/2) C(q_{k-1}) dv_body``: the n-frame turn at the middle of the interval."""
    dv_nav = quat_to_dcm(q) @ dv_body
    return dv_nav - ca.cross(nav_rate_dt, dv_nav) / 2


def step_expr(state, dtheta, dv, earth_rate_dt, gravity_dt, previous_scale=1):
    """Next navigation state from the current one and compensated increments (CasADi).

    ``previous_scale`` multiplies the previous increments in the coning and sculling terms: 1 for
    uniform steps, 0 where the step length changes (block-summed static segments).
    """
    q, v = state[Q], state[V]
    phi, dv_body = corrected_increments(dtheta, dv, previous_scale * state[PREV_DTHETA],
                                        previous_scale * state[PREV_DV])
    v_next = v + specific_force_increment(q, dv_body, earth_rate_dt) + gravity_dt
    return ca.vertcat(attitude_update(q, phi, earth_rate_dt), v_next, dtheta, dv)


@functools.lru_cache(maxsize=None)
def step_function() -> ca.Function:
    """The strapdown step ``(state[13], dtheta[3], dv[3], earth_rate_dt[3], gravity_dt[3], previous_scale)
    -> state``."""
    x = ca.SX.sym("x", STATE_SIZE)
    dth, dv = ca.SX.sym("dtheta", 3), ca.SX.sym("dv", 3)
    wdt, gdt, scale = ca.SX.sym("earth_rate_dt", 3), ca.SX.sym("gravity_dt", 3), ca.SX.sym("previous_scale")
    return ca.Function("strapdown_step", [x, dth, dv, wdt, gdt, scale], [step_expr(x, dth, dv, wdt, gdt, scale)],
                       ["x", "dtheta", "dv", "earth_rate_dt", "gravity_dt", "previous_scale"], ["x_next"])


@functools.lru_cache(maxsize=32)
def chain_function(n_steps: int) -> ca.Function:
    """``n_steps`` strapdown steps chained with ``mapaccum``; returns every intermediate state."""
    return step_function().mapaccum("strapdown_chain", n_steps)


# --------------------------------------------------------------------------- alignment
def alignment_expr(mean_specific_force, mean_rate):
    """Coarse analytic alignment ``C_b^n`` (ENU) from mean body specific force and rate (eq. 14).

    Tilt comes from the accelerometers alone (up = f/|f|) and heading from the
    gyros (east = w x f): gyro errors do not leak into the tilt (pitfall 6).
    """
    up = mean_specific_force / ca.norm_2(mean_specific_force)
    east = ca.cross(mean_rate, mean_specific_force)
    east = east / ca.norm_2(east)
    north = ca.cross(up, east)
    return ca.vertcat(east.T, north.T, up.T)


@functools.lru_cache(maxsize=None)
def alignment_function() -> ca.Function:
    f, w = ca.SX.sym("f", 3), ca.SX.sym("w", 3)
    return ca.Function("alignment", [f, w], [alignment_expr(f, w)], ["f", "w"], ["C_bn"])


def align(dtheta: np.ndarray, dv: np.ndarray, dt: float) -> np.ndarray:
    """Attitude ``C_b^n`` from compensated static increments (rows of samples)."""
    f = np.asarray(dv).mean(axis=0) / dt
    w = np.asarray(dtheta).mean(axis=0) / dt
    return np.asarray(alignment_function()(f, w))


# --------------------------------------------------------------------------- navigation
@dataclasses.dataclass
class GroupNavigation:
    """Navigation of one group: state after each sample of the group's span."""

    group: int
    samples: slice  # indices into the recording
    time: np.ndarray
    velocity: np.ndarray  # (N, 3) ENU, m/s
    quaternion: np.ndarray  # (N, 4) q_b^n
    initial_attitude: np.ndarray  # C_b^n at the start of the span

    def attitude(self, k: int) -> np.ndarray:
        return quat_to_dcm_np(self.quaternion[k])


def static_velocities(rec: Recording, navs: list[GroupNavigation]):
    """``(segment, time, velocity)`` of every static segment of the navigated groups, in schedule order."""
    for nav in navs:
        for seg in rec.group_segments(nav.group):
            if seg.is_static:
                sl = rec.segment_samples(seg)
                local = slice(sl.start - nav.samples.start, sl.stop - nav.samples.start)
                yield seg, nav.time[local], nav.velocity[local]


def navigation_constants(rec: Recording) -> tuple[np.ndarray, np.ndarray]:
    """``(earth_rate_dt, gravity_dt)`` in ENU for one sample interval."""
    return rec.site.earth_rate * rec.dt, np.array([0.0, 0.0, -rec.site.g]) * rec.dt


def compensated_increments(rec: Recording, params, samples: slice | None = None):
    """Compensated ``(dtheta, dv)`` of a recording (or a range of its samples)."""
    samples = samples if samples is not None else slice(None)
    return P.compensate(rec.gyro[samples], rec.accel[samples], params, rec.dt)


def group_alignment(rec: Recording, group: int, params) -> np.ndarray:
    """Coarse alignment of a group on its first static segment."""
    first = rec.group_segments(group)[0]
    dth, dv = compensated_increments(rec, params, rec.segment_samples(first))
    return align(dth, dv, rec.dt)


def navigate_group(rec: Recording, group: int, params, initial_attitude: np.ndarray | None = None
                   ) -> GroupNavigation:
    """Navigate one group from its alignment (or a given start attitude) with parameters ``params``."""
    params = np.asarray(params, dtype=float)
    span = rec.group_samples(group)
    dth, dv = compensated_increments(rec, params, span)
    if initial_attitude is None:
        first = rec.segment_samples(rec.group_segments(group)[0])
        local = slice(first.start - span.start, first.stop - span.start)
        initial_attitude = align(dth[local], dv[local], rec.dt)
    x0 = np.concatenate([dcm_to_quat(initial_attitude), np.zeros(3), dth[0], dv[0]])
    wdt, gdt = navigation_constants(rec)
    states = np.asarray(chain_function(len(dth))(x0, dth.T, dv.T, wdt, gdt, 1.0)).T
    return GroupNavigation(group, span, rec.time[span], states[:, V], states[:, Q], np.asarray(initial_attitude))


def navigate(rec: Recording, params, initial_attitudes: dict[int, np.ndarray] | None = None
             ) -> list[GroupNavigation]:
    """Navigate every group of a recording; one :class:`GroupNavigation` per group."""
    initial_attitudes = initial_attitudes or {}
    return [navigate_group(rec, g, params, initial_attitudes.get(g)) for g in rec.group_ids]
