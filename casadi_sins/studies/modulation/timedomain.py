"""Time-domain check: simulate the turning IMU with drawn errors, navigate free-inertially, Monte Carlo.

Independent of the error-state model: the truth is the exact kinematics of the scheme (the attitude
``C(t) = C0 R(u, w t)`` of each piece, increments by 6-point Gauss-Legendre quadrature of
``w_b = C^T w_ie + w u`` and ``f_b = C^T (0, 0, g)``), the sensors err by the convention of
Kang et al. 2013, eqs. 5-12, plus the asymmetry of Guan et al. 2023, eq. 33
(``d_w = T_g w + eps + dK* |w|``, ``d_f = T_a f + Delta``, white noise of densities ARW and VRW), and
the navigation is the package's free-inertial step written in NumPy for a batch of runs at once
(:func:`casadi_sins.nav.free_inertial.free_inertial_step_expr` is the CasADi original): two-sample
coning and sculling,
``q_k = q(-w_in dt) q_{k-1} q(phi)``, ``v += (I - [w_in dt x]/2) C dv + (g - (2 w_ie + w_en) x v) dt``,
vertical channel held at the known height, position by the mean velocity.

Every run's error is taken against an error-free run through the same steps (the algorithm's own
error, common to all runs and below a metre a day, cancels).  Turns are stepped by at most
``turn_step_deg``, dwells by at most ``dwell_step_s`` (exact for a still IMU: the body and frame
rotations commute away).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...core import earth
from ...core.earth import Site
from ...core.errors import InputError
from ...core.rotations import dcm_to_quat, quat_from_rotvec, quat_multiply, quat_to_dcm
from . import model as M
from .covariance import check_run, check_turn_step, output_pieces
from .schemes import Piece, Scheme, scheme_pieces
from .sources import GROUPS, NOISES, Sources

_GX, _GW = np.polynomial.legendre.leggauss(6)


def true_increments(piece: Piece, site: Site, tau0: float, h: float):
    """Exact ``(dtheta, dv, int |w| dt)`` of the IMU over ``[tau0, tau0 + h]`` of a piece (body, SI)."""
    tau = tau0 + h * (1 + _GX) / 2
    c = piece.attitude_at(tau)
    w = np.einsum("nji,j->ni", c, site.earth_rate) + piece.table_rate()
    f = c[:, 2, :] * site.g
    weights = h * _GW / 2
    return weights @ w, weights @ f, weights @ np.abs(w)


@dataclasses.dataclass
class Errors:
    """Drawn sensor and initial errors of a batch of runs (state order of :mod:`model`).

    Attributes
    ----------
    x0 : ndarray (N, 31)
        Initial error state of each run.
    gyro_arw, accel_vrw : ndarray (N, 3)
        White-noise densities of each run, rad/sqrt(s) and m/s/sqrt(s).
    """

    x0: np.ndarray
    gyro_arw: np.ndarray
    accel_vrw: np.ndarray

    def matrices(self):
        """``(T_g, T_a)`` of every run, (N, 3, 3) each: scale errors on the diagonal, misalignments off it."""
        n = len(self.x0)
        t_g, t_a = np.zeros((n, 3, 3)), np.zeros((n, 3, 3))
        t_g[:, [0, 1, 2], [0, 1, 2]] = self.x0[:, M.GYRO_SCALE]
        t_a[:, [0, 1, 2], [0, 1, 2]] = self.x0[:, M.ACCEL_SCALE]
        for m, (i, j) in enumerate(M.GYRO_MISALIGN_ENTRIES):
            t_g[:, i, j] = self.x0[:, M.GYRO_MISALIGN.start + m]
        for m, (i, j) in enumerate(M.ACCEL_MISALIGN_ENTRIES):
            t_a[:, i, j] = self.x0[:, M.ACCEL_MISALIGN.start + m]
        return t_g, t_a


def draw_errors(sources: Sources, runs: int, rng: np.random.Generator,
                matched: bool = False) -> tuple[Errors, list[str]]:
    """``runs`` draws of every source alone, one source after the other, after one error-free run.

    ``matched``: moment-matched sampling (variance reduction): the standard normal draws of a group are
    whitened so that their second moment over the runs is exactly the identity; the drawn errors then
    have the group's covariance as their mean square, and an MC of them tests the propagation rather
    than the luck of 50 draws of one or three numbers.  Noise is never matched, nor a group of more
    numbers than ``runs`` (then drawn plainly).
    """
    labels, x0, arw, vrw = ["reference"], [np.zeros(M.N_STATE)], [np.zeros(3)], [np.zeros(3)]
    for group in GROUPS:
        p = sources.group_covariance(group)
        idx = GROUPS[group]
        block = p[np.ix_(idx, idx)]
        if not np.any(block):
            continue
        vals, vecs = np.linalg.eigh(block)
        root = vecs * np.sqrt(np.clip(vals, 0.0, None))  # root @ root.T == block
        z = rng.standard_normal((runs, len(idx)))
        if matched and runs >= len(idx):  # fewer runs than numbers cannot have the identity as second moment
            z = z @ np.linalg.inv(np.linalg.cholesky(z.T @ z / runs)).T
        draws = np.zeros((runs, M.N_STATE))
        draws[:, idx] = z @ root.T
        x0.extend(draws @ sources.initial_map().T)  # through the alignment, if any
        arw.extend([np.zeros(3)] * runs)
        vrw.extend([np.zeros(3)] * runs)
        labels.extend([group] * runs)
    for name, dens in zip(NOISES, (sources.gyro_arw, sources.accel_vrw)):
        if not np.any(dens):
            continue
        x0.extend([np.zeros(M.N_STATE)] * runs)
        arw.extend([dens if name == "gyro noise" else np.zeros(3)] * runs)
        vrw.extend([dens if name == "accel noise" else np.zeros(3)] * runs)
        labels.extend([name] * runs)
    return Errors(np.array(x0), np.array(arw), np.array(vrw)), labels


def navigate(scheme: Scheme, site: Site, hours: float, errors: Errors, rng: np.random.Generator,
             turn_step_deg: float = 1.0, dwell_step_s: float = 5.0, max_step_s: float = 60.0, progress=None):
    """Free-inertial navigation of every run; errors (v_E, v_N, north, east) at each output time.

    Returns ``(time (T,), errors (T, N, 4), reference (T, 4))``: the errors against the error-free run
    (index 0) and that run's own error (the algorithm's); the output times are those of
    :func:`covariance.propagate` with the same ``max_step_s``.  ``progress(fraction)``, if given, after
    each output time with the fraction of the run's time navigated.
    """
    check_turn_step(turn_step_deg, "navigation step")
    if not (math.isfinite(dwell_step_s) and dwell_step_s > 0):
        raise InputError(None, f"navigation step in a dwell must be a positive number of seconds (got {dwell_step_s})")
    check_run(scheme, site, hours, max_step_s)
    pieces = output_pieces(scheme_pieces(scheme, hours * 3600.0), max_step_s)
    n = len(errors.x0)
    t_g, t_a = errors.matrices()
    eps, delta = errors.x0[:, M.GYRO_BIAS], errors.x0[:, M.ACCEL_BIAS]
    asym = errors.x0[:, M.GYRO_ASYM]
    r_m, r_n = earth.earth_radii(site.latitude)
    lat0, h0 = site.latitude, site.height
    c0 = pieces[0].attitude
    q = np.array([quat_multiply(quat_from_rotvec(-phi), dcm_to_quat(c0)) for phi in errors.x0[:, M.PHI]])
    v = np.zeros((n, 3))
    lat, lon = np.full(n, lat0), np.zeros(n)
    out_t, out = [0.0], [np.zeros((n, 4))]
    for piece in pieces:
        steps = (max(1, math.ceil(abs(piece.rate) * piece.duration / math.radians(turn_step_deg) - 1e-9))
                 if piece.axis is not None else max(1, math.ceil(piece.duration / dwell_step_s - 1e-9)))
        h = piece.duration / steps
        prev_th, prev_dv = np.zeros((n, 3)), np.zeros((n, 3))
        for k in range(steps):
            th_true, dv_true, th_abs = true_increments(piece, site, k * h, h)
            th = (th_true + np.einsum("nij,j->ni", t_g, th_true) + eps * h + asym * th_abs
                  + errors.gyro_arw * math.sqrt(h) * rng.standard_normal((n, 3)))
            dv = (dv_true + np.einsum("nij,j->ni", t_a, dv_true) + delta * h
                  + errors.accel_vrw * math.sqrt(h) * rng.standard_normal((n, 3)))
            q, v, lat, lon = _step(q, v, lat, lon, th, dv, prev_th, prev_dv, h, site)
            prev_th, prev_dv = th, dv
        out_t.append(piece.t0 + piece.duration)
        if progress:
            progress(out_t[-1] / (hours * 3600.0))
        out.append(np.column_stack([v[:, 0], v[:, 1], (lat - lat0) * (r_m + h0), lon * (r_n + h0) * np.cos(lat0)]))
    err = np.array(out)
    return np.array(out_t), err - err[:, :1, :], err[:, 0, :]


def _step(q, v, lat, lon, th, dv, prev_th, prev_dv, h, site: Site):
    """One free-inertial step for every run (the vertical channel held)."""
    r_m, r_n = earth.earth_radii(lat)
    r_m, r_n = r_m + site.height, r_n + site.height
    cl, sl = np.cos(lat), np.sin(lat)
    w_ie = earth.EARTH_RATE * np.column_stack([np.zeros_like(lat), cl, sl])
    w_en = np.column_stack([-v[:, 1] / r_m, v[:, 0] / r_n, v[:, 0] * sl / cl / r_n])
    w_in_h = (w_ie + w_en) * h
    phi = th + np.cross(prev_th, th) / 12.0
    dv_body = (dv + np.cross(th, dv) / 2.0 + np.cross(th, np.cross(th, dv)) / 6.0
               + (np.cross(prev_th, dv) + np.cross(prev_dv, th)) / 12.0)
    dv_nav = np.einsum("nij,nj->ni", quat_to_dcm(q), dv_body)
    dv_nav = dv_nav - np.cross(w_in_h, dv_nav) / 2.0
    v_next = v + dv_nav - np.cross(2 * w_ie + w_en, v) * h
    v_next[:, 2] = 0.0  # vertical channel held at the known height (gravity and f_U cancel there)
    v_mid = 0.5 * (v + v_next)
    lat_next = lat + v_mid[:, 1] / r_m * h
    lon_next = lon + v_mid[:, 0] / (r_n * cl) * h
    q_next = quat_multiply(quat_multiply(quat_from_rotvec(-w_in_h), q), quat_from_rotvec(phi))
    q_next /= np.linalg.norm(q_next, axis=1, keepdims=True)
    return q_next, v_next, lat_next, lon_next

