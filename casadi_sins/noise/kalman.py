"""The noise of the estimator's residuals as a linear state-space model, and its Kalman whitener.

The residuals of the NLP (:mod:`noise.observations`) are the navigated velocity at observation times in static segments and
the mean gyro rate of every static segment.  Sensor noise moves them through one linear model
(the error dynamics of the method (docs/method.md) on a static base, ENU; the slow ``-w_ie x phi`` term kept to
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
(:mod:`calibrate.nlp.likelihood`).
A velocity observation is ``dv + C e_a`` (``e_a``: the accelerometers' pulse remainder), a static gyro
mean ``a / T + (e_g,end - e_g,start) / T`` plus the base's sway (:mod:`noise.motion`).  The
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

from ..core.rotations import skew
from ..model.noise import SensorNoise
from .observations import Observation, ObservationKind

#: The states every layout has: attitude error, velocity error, the segment's gyro angle, and the
#: attitude error at the segment's middle step.
PHI, DV, ACC, PM = (slice(3 * k, 3 * k + 3) for k in range(4))
BASE_STATES = 12


@dataclasses.dataclass(frozen=True)
class Layout:
    """The state vector: attitude, velocity, the segment's gyro angle and the attitude at the segment's
    middle (always); Gauss-Markov biases and the unmodelled acceleration when the model has them."""

    markov: bool
    unmodelled: bool

    @property
    def bg(self) -> slice:
        """The gyro Gauss-Markov bias."""
        return slice(BASE_STATES, BASE_STATES + 3)

    @property
    def ba(self) -> slice:
        """The accelerometer Gauss-Markov bias."""
        return slice(BASE_STATES + 3, BASE_STATES + 6)

    @property
    def ua(self) -> slice:
        """The unmodelled acceleration of the current static segment."""
        start = BASE_STATES + (6 if self.markov else 0)
        return slice(start, start + 3)

    @property
    def n(self) -> int:
        """Number of states."""
        return BASE_STATES + (6 if self.markov else 0) + (3 if self.unmodelled else 0)

    @classmethod
    def of(cls, noise: SensorNoise) -> "Layout":
        """The layout a noise model needs."""
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


def gauss_markov_integrals(h, tau: float):
    """Discretisation of a first-order Gauss-Markov bias ``b' = -b / tau`` over ``h`` seconds.

    Returns ``(beta, gamma1, gamma2)``: ``beta = exp(-h / tau)`` carries the bias, ``gamma1 =
    int_0^h beta(s) ds`` is the angle (or velocity) it adds, ``gamma2 = int_0^h gamma1(s) ds`` what
    that adds through a further integration (a tilt into velocity).
    """
    beta = np.exp(-h / tau)
    gamma1 = tau * (1.0 - beta)
    return beta, gamma1, tau * (h - gamma1)


@dataclasses.dataclass
class GroupTrack:
    """What the noise model needs of one group: its steps and observations, in time order."""

    start_time: float
    step_dt: np.ndarray  # (M,)
    attitude: np.ndarray  # (M, 3, 3) C_b^n during each step
    segment_start: np.ndarray  # (M,) bool: first step of a static segment
    static: np.ndarray  # (M,) bool: step inside a static segment
    free_velocity: np.ndarray  # (M,) bool: the velocity offset is free from this step on (rotation step dropped)
    observations: list[Observation]
    segment_duration: dict[int, float]  # static segment index -> duration (s)
    segment_sway: dict[int, np.ndarray]  # static segment index -> variance added to its mean rate, (rad/s)^2
    segment_mid_of: dict[int, int] = dataclasses.field(default_factory=dict)  # segment -> its middle step

    @property
    def segment_mid(self) -> set[int]:
        """Steps whose end attitude a static segment's gyro mean uses."""
        return set(self.segment_mid_of.values())

    @property
    def observations_at(self) -> dict[int, list[Observation]]:
        """Step -> the observations made at its end."""
        out: dict[int, list[Observation]] = {}
        for obs in self.observations:
            out.setdefault(obs.step, []).append(obs)
        return out

    @property
    def end_time(self) -> float:
        """End of the group's last step, s."""
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
        self.rows = max((obs.row + 3 for t in tracks for obs in t.observations), default=0)

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
                beta, gamma1, gamma2 = gauss_markov_integrals(h, tau)
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
                    bu, g1, g2 = gauss_markov_integrals(h * (1.0 + x) / 2.0, tau)
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
        run = _Filter(self, noise, columns)
        previous_end = None
        for track in self.tracks:
            run.start_group(track, previous_end)
            phi, q = self.transitions(track, noise, run.layout)
            mids = track.segment_mid
            at_step = track.observations_at
            for k in range(len(track.step_dt)):
                run.start_step(track, k)
                run.predict(phi[k], q[k])
                if k in mids:
                    run.keep_middle_attitude()
                for obs in at_step.get(k, ()):
                    run.observe(track, k, obs)
            previous_end = track.end_time
        return Whitened(run.out, run.log_det, self.rows)


class _Filter:
    """One pass of the Kalman filter over the tracks: state, covariance, whitened rows, log-likelihood."""

    def __init__(self, system: NoiseSystem, noise: SensorNoise, columns: np.ndarray):
        self.system, self.noise, self.columns = system, noise, columns
        self.layout = Layout.of(noise)
        n = self.layout.n
        self.out = np.zeros_like(columns)
        self.x = np.zeros((n, columns.shape[1]))
        self.p = np.zeros((n, n))
        if self.layout.markov:
            self.p[self.layout.bg, self.layout.bg] = np.eye(3) * noise.gyro_bias_instability**2
            self.p[self.layout.ba, self.layout.ba] = np.eye(3) * noise.accel_bias_instability**2
        self.q_a = noise.accel_quantization**2
        self.q_g = noise.gyro_quantization**2
        self.log_det = 0.0
        self.offset = np.zeros((3, columns.shape[1]))  # observed velocity of a free offset's reference
        self.free_pending = False

    def _reset(self, *slices):
        for sl in slices:
            self.x[sl] = 0.0
            self.p[sl, :] = 0.0
            self.p[:, sl] = 0.0

    def start_group(self, track: GroupTrack, previous_end: float | None) -> None:
        """A new group: the biases wander on since the last one; attitude free (estimated), velocity zero
        up to the accelerometers' remainder."""
        noise, layout, p = self.noise, self.layout, self.p
        if layout.markov and previous_end is not None:
            for sl, sigma, tau in ((layout.bg, noise.gyro_bias_instability, noise.gyro_bias_tau),
                                   (layout.ba, noise.accel_bias_instability, noise.accel_bias_tau)):
                beta = gauss_markov_integrals(max(track.start_time - previous_end, 0.0), tau)[0]
                self.x[sl] *= beta
                p[sl, :] *= beta
                p[:, sl] *= beta
                p[sl, sl] += np.eye(3) * sigma**2 * (1.0 - beta**2)
        self._reset(PHI, DV, ACC, PM, *((layout.ua,) if layout.unmodelled else ()))
        c0 = track.attitude[0]
        self.p[DV, DV] = (c0 * self.q_a) @ c0.T
        self.offset = np.zeros((3, self.columns.shape[1]))
        self.free_pending = False

    def start_step(self, track: GroupTrack, k: int) -> None:
        """At a static segment's first step: the rotation's velocity error, a new gyro angle and unmodelled
        acceleration; a free velocity offset from here on when the rotation's step is not used."""
        layout = self.layout
        if track.segment_start[k] and k > 0:
            self.p[DV, DV] += np.eye(3) * (ROTATION_METHOD_ERROR**2 + self.noise.unmodelled_step**2)
        if track.segment_start[k]:
            self._reset(ACC, *((layout.ua,) if layout.unmodelled else ()))
            if layout.unmodelled:
                self.p[layout.ua, layout.ua] = np.eye(3) * self.noise.unmodelled_acceleration**2
        self.free_pending |= bool(track.free_velocity[k])

    def predict(self, phi: np.ndarray, q: np.ndarray) -> None:
        """Propagate state and covariance over one step."""
        self.x = phi @ self.x
        self.p = phi @ self.p @ phi.T + q

    def keep_middle_attitude(self) -> None:
        """Keep the attitude error of the step whose attitude the segment's gyro mean uses."""
        x, p = self.x, self.p
        x[PM] = x[PHI]
        p[PM, :] = p[PHI, :]
        p[:, PM] = p[:, PHI]
        p[PM, PM] = p[PHI, PHI]

    def observe(self, track: GroupTrack, k: int, obs: Observation) -> None:
        """Whiten one observation's three rows and update the state with it."""
        n = self.layout.n
        row = obs.row
        if obs.kind == ObservationKind.VELOCITY:
            ck = track.attitude[k]
            r_obs = (ck * self.q_a) @ ck.T + np.eye(3) * VELOCITY_FLOOR
            if self.free_pending:
                # a free velocity offset: this observation only sets it.  From here on the velocity counts
                # from it, so its error restarts at minus its remainder.
                self.offset = self.columns[row:row + 3].copy()
                self._reset(DV)
                self.p[DV, DV] = r_obs
                self.out[row:row + 3] = 0.0
                self.free_pending = False
                return
            h = np.zeros((3, n))
            h[:, DV] = np.eye(3)
            reference = self.offset
        else:
            duration = track.segment_duration[obs.segment]
            r_obs = np.diag(2.0 * self.q_g / duration**2 + track.segment_sway.get(obs.segment, 0.0)
                            + self.noise.unmodelled_rate**2 + GYRO_FLOOR)
            # mean rate - C_nav^T w_ie: the gyro angle over the duration, and the navigated attitude's error
            # at the middle turning the Earth rate (C^T [w_ie x] phi)
            h = np.zeros((3, n))
            h[:, ACC] = np.eye(3) / duration
            h[:, PM] = track.attitude[track.segment_mid_of[obs.segment]].T @ self.system.earth_cross
            reference = 0.0
        self._update(row, h, r_obs, reference)

    def _update(self, row: int, h: np.ndarray, r_obs: np.ndarray, reference) -> None:
        p = self.p
        ph = p @ h.T  # P H^T
        s = h @ ph + r_obs
        s = 0.5 * (s + s.T)
        chol = np.linalg.cholesky(s)
        innovation = self.columns[row:row + 3] - reference - h @ self.x
        self.out[row:row + 3] = np.linalg.solve(chol, innovation)
        self.log_det += 2.0 * float(np.sum(np.log(np.diag(chol))))
        gain = np.linalg.solve(s, ph.T).T  # P H^T S^-1
        self.x = self.x + gain @ innovation
        i_kh = np.eye(self.layout.n) - gain @ h
        self.p = i_kh @ p @ i_kh.T + gain @ r_obs @ gain.T
