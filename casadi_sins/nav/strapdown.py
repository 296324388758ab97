"""The one strapdown step on a static base, as a CasADi ``Function``.

The navigation frame is ENU at the test site, fixed to the Earth; the base does not move, so the
transport rate and Coriolis terms vanish (the paper's experiment, section 2) and the n frame turns with the Earth rate
only.  One step from sample ``k-1`` to ``k`` (quaternion ``q = q_b^n``, velocity ``v``)::

    phi_k   = dtheta_k + dtheta_{k-1} x dtheta_k / 12                 (coning)
    dv_rot  = dtheta_k x dv_k / 2 + dtheta_k x (dtheta_k x dv_k) / 6  (rotation, 1st + 2nd order)
    dv_scul = (dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k) / 12        (sculling)
    v_k     = v_{k-1} + (I - [w_ie dt x]/2) C(q_{k-1}) (dv_k + dv_rot + dv_scul) + g^n dt
    q_k     = q(-w_ie dt) * q_{k-1} * q(phi_k)

Without the second-order rotation term a 90 deg rotation at 14 deg/s peak leaves a velocity step of
(h^2 g / 6) int w^2 dt = 5e-5 m/s along gravity; with it, the step is exact to O(h^3) for rotation
about a fixed axis.  The half-step n-frame rotation in the velocity update puts the Earth-rate
correction at the middle of the interval (physics pitfall 4).  Chained with ``mapaccum`` the step is
the numeric navigation (:mod:`nav.navigation`), and the same object is the symbolic graph of the
estimator (:mod:`calibrate.nlp.graph`).
"""

from __future__ import annotations

import functools

import casadi as ca

from ..core.rotations import quat_from_rotvec_expr, quat_multiply_expr, quat_to_dcm_expr

STATE_SIZE = 13  # q (4: w, x, y, z), v (3), previous dtheta (3), previous dv (3)
Q, V, PREV_DTHETA, PREV_DV = slice(0, 4), slice(4, 7), slice(7, 10), slice(10, 13)


def corrected_increments(dtheta, dv, dtheta_prev, dv_prev):
    """Rotation vector and body velocity increment of one step: coning, rotation (1st and 2nd order) and
    sculling corrections from the current and previous compensated increments."""
    phi = dtheta + ca.cross(dtheta_prev, dtheta) / 12
    rotation = ca.cross(dtheta, dv) / 2 + ca.cross(dtheta, ca.cross(dtheta, dv)) / 6
    dv_body = dv + rotation + (ca.cross(dtheta_prev, dv) + ca.cross(dv_prev, dtheta)) / 12
    return phi, dv_body


def attitude_update(q, phi, nav_rate_dt):
    """``q_k = q(-w_in dt) * q_{k-1} * q(phi)``, normalised."""
    q_next = quat_multiply_expr(quat_multiply_expr(quat_from_rotvec_expr(-nav_rate_dt), q),
                                quat_from_rotvec_expr(phi))
    return q_next / ca.norm_2(q_next)


def specific_force_increment(q, dv_body, nav_rate_dt):
    """``(I - [w_in dt x]/2) C(q_{k-1}) dv_body``: the n-frame turn at the middle of the interval."""
    dv_nav = quat_to_dcm_expr(q) @ dv_body
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
