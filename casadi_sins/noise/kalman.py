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

import numpy as np

from ..core.rotations import skew
from ..model.noise import SensorNoise
from .filter import whiten
from .statespace import (ACC, BASE_STATES, DV, GYRO_FLOOR, PHI, PM, ROTATION_METHOD_ERROR, VELOCITY_FLOOR, GroupTrack,
                         Layout, Whitened, gauss_markov_integrals)

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
        self.f_cross = skew(np.array([0.0, 0.0, gravity]))
        self.earth_cross = skew(np.asarray(earth_rate, dtype=float))
        self.rows = max((obs.row + 3 for t in tracks for obs in t.observations), default=0)

    # ------------------------------------------------------------------ discretisation
    def transitions(self, track: GroupTrack, noise: SensorNoise, layout: Layout):
        """``Phi`` (M, n, n) and ``Q`` (M, n, n) of every step (exact for a constant attitude in the step)."""
        phi, terms = self.covariance_terms(track, noise, layout)
        q = np.zeros_like(phi)
        for variance, unit in terms:
            if variance:
                q += variance * unit
        return phi, q

    def covariance_terms(self, track: GroupTrack, noise: SensorNoise, layout: Layout):
        """``Phi`` (M, n, n) of every step and its covariance as terms ``(variance, unit covariance (M, n, n))``.

        The terms: the white gyro noise of each axis (ARW^2), the white accelerometer noise of each axis
        (VRW^2), and with Gauss-Markov biases the gyro's and the accelerometer's instability^2; the
        transitions depend on the correlation times only, so a likelihood search over the variances reuses
        them (:mod:`noise.filter`).
        """
        n = layout.n
        h = track.step_dt
        c = track.attitude
        m = len(h)
        eye3 = np.eye(3)
        phi = np.tile(np.eye(n), (m, 1, 1))
        phi[:, PHI, PHI] -= self.earth_cross[None] * h[:, None, None]
        phi[:, DV, PHI] = self.f_cross[None] * h[:, None, None]
        # white gyro noise: Phi(u) G = V0 + V1 u (u = time to the end of the step); white accelerometer noise: W0
        v0 = np.zeros((m, n, 3))
        v0[:, PHI] = -c
        v0[:, ACC] = eye3
        v1 = np.zeros((m, n, 3))
        v1[:, DV] = -self.f_cross @ c
        w0 = np.zeros((m, n, 3))
        w0[:, DV] = c
        h1, h2, h3 = (h[:, None, None] ** k / k for k in (1, 2, 3))
        units = []
        for axis in range(3):
            a, b = v0[:, :, axis, None], v1[:, :, axis, None]
            cross = a @ np.swapaxes(b, 1, 2)
            units.append(a @ np.swapaxes(a, 1, 2) * h1 + (cross + np.swapaxes(cross, 1, 2)) * h2
                         + b @ np.swapaxes(b, 1, 2) * h3)
        for axis in range(3):
            a = w0[:, :, axis, None]
            units.append(a @ np.swapaxes(a, 1, 2) * h1)
        if layout.unmodelled:  # unmodelled acceleration: constant within a static segment
            phi[:, DV, layout.ua] = eye3 * (h * track.static)[:, None, None]
        if layout.markov:
            units += self._gauss_markov(phi, track, noise, layout)
        return phi, list(zip(self.term_variances(noise, layout), units))

    @staticmethod
    def term_variances(noise: SensorNoise, layout: Layout) -> list[float]:
        """The variances of :meth:`covariance_terms`' terms, in order."""
        out = [float(v) ** 2 for v in noise.gyro_arw] + [float(v) ** 2 for v in noise.accel_vrw]
        if layout.markov:
            out += [float(noise.gyro_bias_instability) ** 2, float(noise.accel_bias_instability) ** 2]
        return out

    def _gauss_markov(self, phi: np.ndarray, track: GroupTrack, noise: SensorNoise, layout: Layout):
        """The biases' part of the transitions (in ``phi``), and their unit covariances (gyro, accelerometer)."""
        n, h, c, m, eye3 = layout.n, track.step_dt, track.attitude, len(track.step_dt), np.eye(3)
        units = []
        for sensor, sl, tau in (("gyro", layout.bg, noise.gyro_bias_tau), ("accel", layout.ba, noise.accel_bias_tau)):
            beta, gamma1, gamma2 = gauss_markov_integrals(h, tau)
            phi[:, sl, sl] = eye3 * beta[:, None, None]
            if sensor == "gyro":
                phi[:, PHI, sl] = -c * gamma1[:, None, None]
                phi[:, ACC, sl] = eye3 * gamma1[:, None, None]
                phi[:, DV, sl] = -(self.f_cross @ c) * gamma2[:, None, None]
            else:
                phi[:, DV, sl] = c * gamma1[:, None, None]
            # Q = (2 sigma^2 / tau) int_0^h Phi(u) G Phi(u)^T... du by 6-point Gauss-Legendre (smooth integrand)
            unit = np.zeros((m, n, n))
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
                unit += (2.0 / tau) * (wgt * h / 2.0)[:, None, None] * (col @ np.swapaxes(col, 1, 2))
            units.append(unit)
        return units

    # ------------------------------------------------------------------ the filter
    def whiten(self, columns: np.ndarray, noise: SensorNoise) -> Whitened:
        """``Sigma^-1/2`` applied to residual columns (rows in residual order) under ``noise``.

        Row blocks of three (one observation) are replaced by their whitened innovations; the Kalman
        filter is :func:`noise.filter.whiten`.
        """
        return whiten(self, columns, noise)
