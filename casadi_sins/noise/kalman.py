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
mean ``a / T + (e_g,end - e_g,start) / T`` plus the base's sway (:mod:`noise.motion`).  A tapered mean
(:mod:`noise.taper`) weighs its steps: the gyro noise enters its angle ``a`` with the step's weight times
``T``, and its middle attitude error is the weighted mean of the attitude errors after the steps.  The
same gyro noise thus enters the gyro means *and* the velocity, through ``f x phi``, and the bias
instability ties the whole recording together; both are in the model.

The Kalman filter over this model turns the residuals into independent unit-variance innovations
(``Sigma^-1/2 r``) in one pass, O(number of steps): the generalised least squares of the estimator
is ordinary least squares on the whitened residuals and Jacobian, and the filter's innovations also
give the likelihood of the noise levels.  Every step of the navigation is a step of the filter, so
the model follows the attitude through the rotations.
"""

from __future__ import annotations

import numpy as np

from ..core.rotations import skew
from ..model.noise import SensorNoise
from .filter import whiten
from .statespace import (ACC, BASE_STATES, DV, GYRO_FLOOR, PHI, PM, ROTATION_METHOD_ERROR, VELOCITY_FLOOR, GroupTrack,
                         Layout, Whitened, axis_shape, gauss_markov_integrals)

__all__ = ["NoiseSystem", "GroupTrack", "Layout", "Whitened", "gauss_markov_integrals", "PHI", "DV", "ACC", "PM",
           "BASE_STATES", "VELOCITY_FLOOR", "GYRO_FLOOR", "ROTATION_METHOD_ERROR"]

#: Nodes of the Gauss-Legendre rule of the bias instability's covariance over a step.
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(6)


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
        self.gravity, self.earth_rate = float(gravity), np.asarray(earth_rate, dtype=float)
        self.f_cross = skew(np.array([0.0, 0.0, gravity]))
        self.earth_cross = skew(np.asarray(earth_rate, dtype=float))
        self.rows = max((obs.row + 3 for t in tracks for obs in t.observations), default=0)
        # the filter's caches, owned here and filled by noise.filter and noise.steps: per track its packed
        # observation rows; per search key how often it was whitened; per key and track the variance components
        self.track_rows: dict = {}
        self.whitenings: dict = {}
        self.components: dict = {}

    # ------------------------------------------------------------------ discretisation
    def transitions(self, track: GroupTrack, noise: SensorNoise, layout: Layout):
        """``Phi`` (M, n, n) and ``Q`` (M, n, n) of every step (exact for a constant attitude in the step)."""
        phi = self.step_transitions(track, noise, layout)
        q = self._white(track, layout, noise.gyro_arw**2, noise.accel_vrw**2)
        for variance, block in zip(self._markov_variances(noise, layout), self._markov_blocks(noise, layout)):
            if variance:  # a bias without instability (the other sensor's datasheet gives one) adds nothing
                q += variance * self._gauss_markov(track, layout, *block)
        return phi, q

    def covariance_terms(self, track: GroupTrack, noise: SensorNoise, layout: Layout):
        """``Phi`` (M, n, n) of every step and its covariance as terms ``(variance, unit covariance (M, n, n))``.

        The terms: the white gyro noise (its largest axis' ARW^2, the axes in the model's proportions,
        :func:`axis_shape`), the white accelerometer noise (VRW^2, likewise), and with Gauss-Markov biases
        the gyro's and the accelerometer's instability^2; the transitions depend on the correlation times
        only, so a likelihood search over the levels reuses them (:mod:`noise.filter`).
        """
        phi = self.step_transitions(track, noise, layout)
        markov = [self._gauss_markov(track, layout, *block) for block in self._markov_blocks(noise, layout)]
        zero = np.zeros(3)
        units = [self._white(track, layout, axis_shape(noise.gyro_arw) ** 2, zero),
                 self._white(track, layout, zero, axis_shape(noise.accel_vrw) ** 2)]
        return phi, list(zip(self.term_variances(noise, layout), units + markov))

    def step_transitions(self, track: GroupTrack, noise: SensorNoise, layout: Layout) -> np.ndarray:
        """``Phi`` (M, n, n) of every step alone, without its covariance (with ``bias_tau = inf`` the
        biases are held constant: the responses of :mod:`noise.pieces`)."""
        n, h = layout.n, track.step_dt
        phi = np.tile(np.eye(n), (len(h), 1, 1))
        phi[:, PHI, PHI] -= self.earth_cross[None] * h[:, None, None]
        phi[:, DV, PHI] = self.f_cross[None] * h[:, None, None]
        if layout.unmodelled:  # unmodelled acceleration: constant within a static segment
            phi[:, DV, layout.ua] = np.eye(3) * (h * track.static)[:, None, None]
        for sensor, sl, tau in self._markov_blocks(noise, layout):
            phi[:, :, sl] = self._bias_input(track, sensor, sl, h, tau, n)
        return phi

    def gyro_mean_observation(self, track: GroupTrack, segment: int) -> np.ndarray:
        """``H`` (3, 6) of a static segment's gyro mean on its gyro angle and middle attitude error:
        ``a / T + C_mid^T [w_ie x] phi_mid``."""
        return np.hstack([np.eye(3) / track.segment_duration[segment],
                          track.attitude[track.segment_mid_of[segment]].T @ self.earth_cross])

    def _white(self, track: GroupTrack, layout: Layout, gyro_variance, accel_variance) -> np.ndarray:
        """The white noise's covariance over each step (M, n, n) for per-axis variances (ARW^2, VRW^2).

        White gyro noise enters as ``Phi(u) G = V0 + V1 u`` (``u`` the time to the end of the step) with
        ``V0 = (-C; I)`` on (attitude, gyro angle) and ``V1 = -F C`` on velocity (``F = [f^n x]``); white
        accelerometer noise as ``C`` on velocity.  ``Q = V0 D V0^T h + (V0 D V1^T + V1 D V0^T) h^2 / 2 + V1 D
        V1^T h^3 / 3 + C D_a C^T h``, written by blocks.
        """
        h, c, f = track.step_dt, track.attitude, self.f_cross
        h1, h2, h3 = (h[:, None, None] ** k / k for k in (1, 2, 3))
        gain = track.gyro_gain[:, None, None]  # the gyro angle's share of the noise (a tapered mean's weight)
        c_d = c * np.asarray(gyro_variance, dtype=float)  # C D
        c_d_c = c_d @ np.swapaxes(c, 1, 2)
        f_c_d = f @ c_d
        q = np.zeros((len(h), layout.n, layout.n))
        q[:, PHI, PHI] = c_d_c * h1
        q[:, PHI, ACC] = -c_d * h1 * gain
        q[:, ACC, PHI] = -np.swapaxes(c_d, 1, 2) * h1 * gain
        q[:, ACC, ACC] = np.diag(gyro_variance) * h1 * gain**2
        q[:, PHI, DV] = c_d_c @ f.T * h2
        q[:, DV, PHI] = f @ c_d_c * h2
        q[:, ACC, DV] = -np.swapaxes(f_c_d, 1, 2) * h2 * gain
        q[:, DV, ACC] = -f_c_d * h2 * gain
        q[:, DV, DV] = f @ c_d_c @ f.T * h3 + (c * np.asarray(accel_variance, dtype=float)) @ np.swapaxes(c, 1, 2) * h1
        return q

    @staticmethod
    def term_variances(noise: SensorNoise, layout: Layout) -> list[float]:
        """The variances of :meth:`covariance_terms`' terms, in order."""
        return [float(np.max(noise.gyro_arw)) ** 2, float(np.max(noise.accel_vrw)) ** 2] + \
            NoiseSystem._markov_variances(noise, layout)

    @staticmethod
    def _markov_variances(noise: SensorNoise, layout: Layout) -> list[float]:
        if not layout.markov:
            return []
        return [float(noise.gyro_bias_instability) ** 2, float(noise.accel_bias_instability) ** 2]

    @staticmethod
    def _markov_blocks(noise: SensorNoise, layout: Layout) -> list[tuple[str, slice, float]]:
        """``(sensor, states, correlation time)`` of the Gauss-Markov biases in the layout (gyro, accelerometer)."""
        if not layout.markov:
            return []
        return [("gyro", layout.bg, noise.gyro_bias_tau), ("accel", layout.ba, noise.accel_bias_tau)]

    def _bias_input(self, track: GroupTrack, sensor: str, sl: slice, h, tau: float, n: int) -> np.ndarray:
        """How a Gauss-Markov bias held over ``h`` (M,) seconds from its value moves the states, ``(M, n, 3)``:
        ``beta`` on itself, through ``gamma1`` the gyro's angle (attitude and segment angle) or the
        accelerometer's velocity, through ``gamma2`` the gyro's tilt into velocity."""
        beta, gamma1, gamma2 = gauss_markov_integrals(h, tau)
        c, col = track.attitude, np.zeros((len(h), n, 3))
        col[:, sl] = np.eye(3) * beta[:, None, None]
        if sensor == "gyro":
            col[:, PHI] = -c * gamma1[:, None, None]
            col[:, ACC] = np.eye(3) * (gamma1 * track.gyro_gain)[:, None, None]
            col[:, DV] = -(self.f_cross @ c) * gamma2[:, None, None]
        else:
            col[:, DV] = c * gamma1[:, None, None]
        return col

    def _gauss_markov(self, track: GroupTrack, layout: Layout, sensor: str, sl: slice, tau: float) -> np.ndarray:
        """A bias' unit covariance over each step (M, n, n): ``Q = (2 / tau) int_0^h Phi(u) G Phi(u)^T du`` by
        6-point Gauss-Legendre (a smooth integrand)."""
        h = track.step_dt
        unit = np.zeros((len(h), layout.n, layout.n))
        for x, wgt in zip(_GAUSS_X, _GAUSS_W):
            col = self._bias_input(track, sensor, sl, h * (1.0 + x) / 2.0, tau, layout.n)
            unit += (2.0 / tau) * (wgt * h / 2.0)[:, None, None] * (col @ np.swapaxes(col, 1, 2))
        return unit

    # ------------------------------------------------------------------ the filter
    def whiten(self, columns: np.ndarray, noise: SensorNoise) -> Whitened:
        """``Sigma^-1/2`` applied to residual columns (rows in residual order) under ``noise``.

        Row blocks of three (one observation) are replaced by their whitened innovations; the Kalman
        filter is :func:`noise.filter.whiten`.
        """
        return whiten(self, columns, noise)
