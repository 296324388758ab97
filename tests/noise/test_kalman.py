"""The Kalman whitener of the residuals' noise model, against covariances written down by hand."""

import numpy as np

from casadi_sins.model.noise import SensorNoise
from casadi_sins.noise.kalman import GroupTrack, NoiseSystem
from casadi_sins.noise.observations import Observation, ObservationKind

G = 9.8


def one_segment(n_obs: int, dt: float = 1.0):
    """One static segment (body = ENU), a velocity observation after every step, the gyro mean at the end."""
    observations = [Observation(ObservationKind.VELOCITY, 3 * k, 1, k, 1) for k in range(n_obs)]
    observations.append(Observation(ObservationKind.GYRO_MEAN, 3 * n_obs, 1, n_obs - 1, 1))
    track = GroupTrack(0.0, np.full(n_obs, dt), np.tile(np.eye(3), (n_obs, 1, 1)),
                       np.r_[True, np.zeros(n_obs - 1, bool)], np.ones(n_obs, bool), np.zeros(n_obs, bool),
                       observations, {1: n_obs * dt}, {}, {1: n_obs // 2})
    return NoiseSystem([track], G, np.zeros(3))


def analytic_covariance(n_obs: int, q_a: float, q_g: float, r_v: float) -> np.ndarray:
    """Rows: v_E, v_N, v_U at t = 1..n, then the gyro mean (x, y, z).

    Velocity random walk ``q_a t``; the gyro noise tilts: ``dv_E = g int int w_N``, ``dv_N = -g int int w_E``
    (``f x phi`` with ``phi' = -w``), covariance ``g^2 q_g (s^2 t / 2 - s^3 / 6)``; the gyro mean ``a/T``
    shares it: ``Cov(dv_E(t), a_N(T)) = g q_g t^2 / 2``.
    """
    t = np.arange(1, n_obs + 1, dtype=float)
    s, u = np.minimum.outer(t, t), np.maximum.outer(t, t)
    m = 3 * n_obs + 3
    cov = np.zeros((m, m))
    rw = q_a * s + r_v * np.eye(n_obs)
    tilt = G**2 * q_g * (s**2 * u / 2 - s**3 / 6)
    east, north, up = (slice(axis, 3 * n_obs, 3) for axis in range(3))
    cov[east, east] = rw + tilt
    cov[north, north] = rw + tilt
    cov[up, up] = rw
    duration = t[-1]
    gyro = 3 * n_obs
    cov[gyro:, gyro:] = np.eye(3) * q_g / duration
    cov[east, gyro + 1] = cov[gyro + 1, east] = G * q_g * t**2 / 2 / duration  # dv_E with the north gyro
    cov[north, gyro] = cov[gyro, north] = -G * q_g * t**2 / 2 / duration
    return cov


def test_whitener_inverts_the_hand_written_covariance():
    n = 12
    q_a, q_g, e_a = 1.5e-8, 3e-13, 2e-5  # VRW^2, ARW^2, accelerometer remainder (m/s)
    noise = SensorNoise(gyro_arw=np.sqrt(q_g), accel_vrw=np.sqrt(q_a), gyro_quantization=0.0,
                        accel_quantization=e_a)
    system = one_segment(n)
    white = system.whiten(np.eye(3 * n + 3), noise).columns  # W = Sigma^-1/2 in the filter's factorisation
    cov = analytic_covariance(n, q_a, q_g, e_a**2)
    for axis in range(3):  # the remainder at the group's start is in every velocity of its axis
        cov[axis:3 * n:3, axis:3 * n:3] += e_a**2
    np.testing.assert_allclose(white @ cov @ white.T, np.eye(3 * n + 3), atol=2e-6)


def test_log_determinant_is_that_of_the_covariance():
    n = 8
    noise = SensorNoise(gyro_arw=1e-6, accel_vrw=2e-4, gyro_quantization=0.0, accel_quantization=0.0)
    cov = analytic_covariance(n, 4e-8, 1e-12, 0.0)
    white = one_segment(n).whiten(np.zeros(3 * n + 3), noise)
    assert abs(white.log_det - np.linalg.slogdet(cov)[1]) < 1e-6


def test_a_free_velocity_offset_makes_the_first_observation_uninformative():
    """Steps across rotations not used: a velocity offset of any size after a rotation changes nothing."""
    n = 10
    noise = SensorNoise(gyro_arw=1e-6, accel_vrw=2e-4, gyro_quantization=0.0, accel_quantization=1e-5)
    system = one_segment(n)
    track = system.tracks[0]
    track.free_velocity[0] = True
    data = np.random.default_rng(1).standard_normal(3 * n + 3) * 1e-4
    shifted = data.copy()
    shifted[: 3 * n] += np.tile([0.3, -0.2, 0.05], n)  # a step of tens of cm/s in every velocity
    a, b = system.whiten(data, noise).columns, system.whiten(shifted, noise).columns
    np.testing.assert_allclose(a, b, atol=1e-9)
    assert np.all(a[:3] == 0.0)
