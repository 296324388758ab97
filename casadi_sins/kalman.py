"""The noise of the estimator's residuals as a linear state-space model, and its Kalman whitener.

The residuals of :mod:`nlp` are the navigated velocity at observation times in static segments and
the mean gyro rate of every static segment.  Sensor noise moves them through one linear model
(the error dynamics of spec section 1 on a static base, ENU; the slow ``-w_ie x phi`` term kept to
first order)::

    phi'  = -w_ie x phi - C (w_g + b_g)        attitude error
    dv'   = f^n x phi + C (w_a + b_a)          velocity error (f^n = g up)
    a'    = w_g + b_g                          gyro angle since the segment began (body)
    b_g'  = -b_g / tau_g + n_g,  b_a' = -b_a / tau_a + n_a       bias instability (Gauss-Markov)

with white ``w_g`` (angle random walk), ``w_a`` (velocity random walk) and the Gauss-Markov drives.
When the fit shows errors outside the model (drift in static segments, misfit of the gyro means), an
*unmodelled* acceleration, constant in each static segment and independent between segments
(``dv' += u``, ``u ~ N(0, s_u^2)`` drawn anew at each segment), and an unmodelled rate on each gyro
mean and a white velocity error at every rotation represent them, with variances from the fit
(:mod:`nlp`).
A velocity observation is ``dv + C e_a`` (``e_a``: the accelerometers' pulse remainder), a static gyro
mean ``a / T + (e_g,end - e_g,start) / T`` plus the base's sway (:func:`noise.base_motion`).  The
same gyro noise thus enters the gyro means *and* the velocity, through ``f x phi``, and the bias
instability ties the whole recording together; both are in the model.

The Kalman filter over this model turns the residuals into independent unit-variance innovations
(``Sigma^-1/2 r``) in one pass, O(number of steps): the generalised least squares of the estimator
is ordinary least squares on the whitened residuals and Jacobian, and the filter's innovations also
give the likelihood of the noise levels.  Every step of the navigation is a step of the filter, so
the model follows the attitude through the rotations.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .frames import skew
from .noise import SensorNoise

PHI, DV, ACC, PM = (slice(3 * k, 3 * k + 3) for k in range(4))


@dataclasses.dataclass(frozen=True)
class Layout:
    """The state vector: attitude, velocity, the segment's gyro angle and the attitude at the segment's
    middle (always); Gauss-Markov biases and the unmodelled acceleration when the model has them."""

    markov: bool
    unmodelled: bool

    @property
    def bg(self) -> slice:
        return slice(12, 15)

    @property
    def ba(self) -> slice:
        return slice(15, 18)

    @property
    def ua(self) -> slice:
        start = 18 if self.markov else 12
        return slice(start, start + 3)

    @property
    def n(self) -> int:
        return 12 + (6 if self.markov else 0) + (3 if self.unmodelled else 0)

    @classmethod
    def of(cls, noise: SensorNoise) -> "Layout":
        noise = noise.complete()
        return cls(noise.gyro_bias_instability > 0 or noise.accel_bias_instability > 0,
                   noise.unmodelled_acceleration > 0)
#: Floors of the observation noise (far below any sensor): velocity (m/s)^2, gyro mean (rad/s)^2.
VELOCITY_FLOOR = 1e-20
GYRO_FLOOR = 1e-30
#: The estimator's own error over a rotation (m/s, 1 sigma): the 40 ms steps and the first-order terms
#: beyond the 21 parameters (0.2 % of the 15 mm/s of a 1 ms time offset), measured on noise-free recordings.
#: Real noise over a rotation is 10-100 times larger; on noise-free data it sets the scale.
ROTATION_METHOD_ERROR = 4e-5
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(6)


@dataclasses.dataclass
class GroupTrack:
    """What the noise model needs of one group: its steps and observations, in time order.

    ``events[k]`` lists the observations made at the end of step ``k`` as ``("v", row)`` (velocity,
    residual rows ``row:row+3``) or ``("g", row, segment_index)`` (mean gyro rate of a static segment).
    """

    start_time: float
    step_dt: np.ndarray  # (M,)
    attitude: np.ndarray  # (M, 3, 3) C_b^n during each step
    segment_start: np.ndarray  # (M,) bool: first step of a static segment
    static: np.ndarray  # (M,) bool: step inside a static segment
    free_velocity: np.ndarray  # (M,) bool: the velocity offset is free from this step on (rotation step dropped)
    events: dict[int, list[tuple]]
    segment_duration: dict[int, float]  # static segment index -> duration (s)
    segment_sway: dict[int, np.ndarray]  # static segment index -> variance added to its mean rate, (rad/s)^2
    segment_mid_of: dict[int, int] = dataclasses.field(default_factory=dict)  # segment -> its middle step

    @property
    def segment_mid(self) -> set[int]:
        return set(self.segment_mid_of.values())

    @property
    def end_time(self) -> float:
        return self.start_time + float(self.step_dt.sum())


@dataclasses.dataclass
class Whitened:
    """Whitened columns (rows in the order of the residuals) and the log-likelihood terms of column 0."""

    columns: np.ndarray
    log_det: float  # sum of log det S over all innovations
    rows: int


class NoiseSystem:
    """The state-space noise model of a recording's residuals (one filter over all groups).

    Parameters
    ----------
    tracks : list of GroupTrack
        In time order.
    gravity : float
    earth_rate : (3,) ndarray
        ``w_ie`` in ENU.
    """

    def __init__(self, tracks: list[GroupTrack], gravity: float, earth_rate: np.ndarray):
        self.tracks = tracks
        self.f_cross = skew(np.array([0.0, 0.0, gravity]))
        self.earth_cross = skew(np.asarray(earth_rate, dtype=float))
        self.rows = max((ev[1] + 3 for t in tracks for evs in t.events.values() for ev in evs), default=0)

    # ------------------------------------------------------------------ discretisation
    def transitions(self, track: GroupTrack, noise: SensorNoise, layout: Layout):
        """``Phi`` (M, n, n) and ``Q`` (M, n, n) of every step (exact for a constant attitude in the step)."""
        n = layout.n
        h = track.step_dt
        c = track.attitude
        m = len(h)
        eye3 = np.eye(3)
        phi = np.tile(np.eye(n), (m, 1, 1))
        phi[:, PHI, PHI] -= self.earth_cross[None] * h[:, None, None]
        phi[:, DV, PHI] = self.f_cross[None] * h[:, None, None]
        # white gyro noise: Phi(u) G = V0 + V1 u (u = time to the end of the step); white accelerometer noise: W0
        q_g = noise.gyro_arw**2
        v0 = np.zeros((m, n, 3))
        v0[:, PHI] = -c
        v0[:, ACC] = eye3
        v1 = np.zeros((m, n, 3))
        v1[:, DV] = -self.f_cross @ c
        h1, h2, h3 = (h[:, None, None] ** k / k for k in (1, 2, 3))
        a = (v0 * q_g) @ np.swapaxes(v0, 1, 2)
        b = (v0 * q_g) @ np.swapaxes(v1, 1, 2)
        d = (v1 * q_g) @ np.swapaxes(v1, 1, 2)
        q = a * h1 + (b + np.swapaxes(b, 1, 2)) * h2 + d * h3
        w0 = np.zeros((m, n, 3))
        w0[:, DV] = c
        q += (w0 * noise.accel_vrw**2) @ np.swapaxes(w0, 1, 2) * h1
        if layout.unmodelled:  # unmodelled acceleration: constant within a static segment
            phi[:, DV, layout.ua] = eye3 * (h * track.static)[:, None, None]
        if layout.markov:
            for sensor, sl, sigma, tau in (("gyro", layout.bg, noise.gyro_bias_instability, noise.gyro_bias_tau),
                                           ("accel", layout.ba, noise.accel_bias_instability, noise.accel_bias_tau)):
                beta = np.exp(-h / tau)
                gamma1 = tau * (1.0 - beta)
                gamma2 = tau * (h - gamma1)
                phi[:, sl, sl] = eye3 * beta[:, None, None]
                if sensor == "gyro":
                    phi[:, PHI, sl] = -c * gamma1[:, None, None]
                    phi[:, ACC, sl] = eye3 * gamma1[:, None, None]
                    phi[:, DV, sl] = -(self.f_cross @ c) * gamma2[:, None, None]
                else:
                    phi[:, DV, sl] = c * gamma1[:, None, None]
                if sigma == 0.0:
                    continue
                # Q = (2 sigma^2 / tau) int_0^h Phi(u) G Phi(u)^T... du by 6-point Gauss-Legendre (smooth integrand)
                for x, wgt in zip(_GAUSS_X, _GAUSS_W):
                    u = h * (1.0 + x) / 2.0
                    bu = np.exp(-u / tau)
                    g1 = tau * (1.0 - bu)
                    g2 = tau * (u - g1)
                    col = np.zeros((m, n, 3))
                    col[:, sl] = eye3 * bu[:, None, None]
                    if sensor == "gyro":
                        col[:, PHI] = -c * g1[:, None, None]
                        col[:, ACC] = eye3 * g1[:, None, None]
                        col[:, DV] = -(self.f_cross @ c) * g2[:, None, None]
                    else:
                        col[:, DV] = c * g1[:, None, None]
                    q += (2.0 * sigma**2 / tau) * (wgt * h / 2.0)[:, None, None] * (col @ np.swapaxes(col, 1, 2))
        return phi, q

    # ------------------------------------------------------------------ the filter
    def whiten(self, columns: np.ndarray, noise: SensorNoise) -> Whitened:
        """``Sigma^-1/2`` applied to residual columns (rows in residual order) under ``noise``.

        Row blocks of three (one observation) are replaced by their whitened innovations.
        """
        noise = noise.complete()
        columns = np.asarray(columns, dtype=float)
        if columns.ndim == 1:
            columns = columns[:, None]
        out = np.zeros_like(columns)
        layout = Layout.of(noise)
        markov, unmodelled, n = layout.markov, layout.unmodelled, layout.n
        BG, BA, UA = layout.bg, layout.ba, layout.ua  # noqa: N806 (state slices, named like the constants)
        x = np.zeros((n, columns.shape[1]))
        p = np.zeros((n, n))
        if markov:
            p[BG, BG] = np.eye(3) * noise.gyro_bias_instability**2
            p[BA, BA] = np.eye(3) * noise.accel_bias_instability**2
        earth_cross = self.earth_cross
        q_a = noise.accel_quantization**2
        q_g = noise.gyro_quantization**2
        log_det = 0.0
        previous_end = None
        for track in self.tracks:
            if markov and previous_end is not None:  # the biases wander on between groups
                for sl, sigma, tau in ((BG, noise.gyro_bias_instability, noise.gyro_bias_tau),
                                       (BA, noise.accel_bias_instability, noise.accel_bias_tau)):
                    beta = np.exp(-max(track.start_time - previous_end, 0.0) / tau)
                    x[sl] *= beta
                    p[sl, :] *= beta
                    p[:, sl] *= beta
                    p[sl, sl] += np.eye(3) * sigma**2 * (1.0 - beta**2)
            # a new group: attitude free (estimated), velocity zero up to the accelerometers' remainder
            for sl in (PHI, DV, ACC, PM) + ((UA,) if unmodelled else ()):
                x[sl] = 0.0
                p[sl, :] = 0.0
                p[:, sl] = 0.0
            c0 = track.attitude[0]
            p[DV, DV] = (c0 * q_a) @ c0.T
            phi, q = self.transitions(track, noise, layout)
            offset = np.zeros((3, columns.shape[1]))  # observed velocity of a free offset's reference
            free_pending = False
            for k in range(len(track.step_dt)):
                if track.segment_start[k] and k > 0:
                    p[DV, DV] += np.eye(3) * (ROTATION_METHOD_ERROR**2 + noise.unmodelled_step**2)
                if track.segment_start[k]:
                    for sl in (ACC, UA) if unmodelled else (ACC,):
                        x[sl] = 0.0
                        p[sl, :] = 0.0
                        p[:, sl] = 0.0
                    if unmodelled:
                        p[UA, UA] = np.eye(3) * noise.unmodelled_acceleration**2
                free_pending |= bool(track.free_velocity[k])
                x = phi[k] @ x
                p = phi[k] @ p @ phi[k].T + q[k]
                if k in track.segment_mid:  # keep the attitude error of the step whose attitude the gyro mean uses
                    x[PM] = x[PHI]
                    p[PM, :] = p[PHI, :]
                    p[:, PM] = p[:, PHI]
                    p[PM, PM] = p[PHI, PHI]
                for event in track.events.get(k, ()):
                    if event[0] == "v":
                        row = event[1]
                        ck = track.attitude[k]
                        r_obs = (ck * q_a) @ ck.T + np.eye(3) * VELOCITY_FLOOR
                        if free_pending:
                            # a free velocity offset: this observation only sets it.  From here on the
                            # velocity counts from it, so its error restarts at minus its remainder.
                            offset = columns[row:row + 3].copy()
                            x[DV] = 0.0
                            p[DV, :] = 0.0
                            p[:, DV] = 0.0
                            p[DV, DV] = r_obs
                            out[row:row + 3] = 0.0
                            free_pending = False
                            continue
                        h = np.zeros((3, n))
                        h[:, DV] = np.eye(3)
                    else:
                        row, seg = event[1], event[2]
                        duration = track.segment_duration[seg]
                        r_obs = np.diag(2.0 * q_g / duration**2 + track.segment_sway.get(seg, 0.0)
                                        + noise.unmodelled_rate**2 + GYRO_FLOOR)
                        # mean rate - C_nav^T w_ie: the gyro angle over the duration, and the navigated
                        # attitude's error at the middle turning the Earth rate (C^T [w_ie x] phi)
                        h = np.zeros((3, n))
                        h[:, ACC] = np.eye(3) / duration
                        h[:, PM] = track.attitude[track.segment_mid_of[seg]].T @ earth_cross
                    ph = p @ h.T  # P H^T
                    s = h @ ph + r_obs
                    s = 0.5 * (s + s.T)
                    chol = np.linalg.cholesky(s)
                    innovation = columns[row:row + 3] - (offset if event[0] == "v" else 0.0) - h @ x
                    out[row:row + 3] = np.linalg.solve(chol, innovation)
                    log_det += 2.0 * float(np.sum(np.log(np.diag(chol))))
                    gain = np.linalg.solve(s, ph.T).T  # P H^T S^-1
                    x = x + gain @ innovation
                    i_kh = np.eye(n) - gain @ h
                    p = i_kh @ p @ i_kh.T + gain @ r_obs @ gain.T
            previous_end = track.end_time
        return Whitened(out, log_det, self.rows)
