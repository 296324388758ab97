"""The pieces of the noise model's state space: the state layout, the tracks, the discretisation constants.

The state (:class:`Layout`): attitude error ``phi``, velocity error ``dv``, the segment's gyro angle,
the attitude error at the segment's middle step, and, when the model has them, Gauss-Markov biases
and the unmodelled acceleration of the current static segment.  :mod:`noise.kalman` builds the
transitions over these states and :mod:`noise.filter` runs the Kalman filter over them.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..model.noise import SensorNoise
from .observations import Observation

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


def axis_shape(values) -> np.ndarray:
    """Per-axis values over their largest (ones when all are zero): the proportions of a noise term's axes."""
    values = np.asarray(values, dtype=float)
    top = float(values.max())
    return values / top if top > 0 else np.ones_like(values)


def gauss_markov_integrals(h, tau: float):
    """Discretisation of a first-order Gauss-Markov bias ``b' = -b / tau`` over ``h`` seconds.

    Returns ``(beta, gamma1, gamma2)``: ``beta = exp(-h / tau)`` carries the bias, ``gamma1 =
    int_0^h beta(s) ds`` is the angle (or velocity) it adds, ``gamma2 = int_0^h gamma1(s) ds`` what
    that adds through a further integration (a tilt into velocity).  ``tau = inf``: a bias held
    constant, ``(1, h, h^2 / 2)``.
    """
    if np.isinf(tau):
        h = np.asarray(h, dtype=float)
        return np.ones_like(h), h.copy(), h**2 / 2.0
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
    # segment -> (its steps, the rate weights u of its tapered gyro mean, noise.taper.rate_weights)
    segment_taper: dict[int, tuple[np.ndarray, np.ndarray]] = dataclasses.field(default_factory=dict)

    @property
    def segment_mid(self) -> set[int]:
        """Steps whose end attitude a plain gyro mean uses (a tapered mean weighs every step's instead)."""
        return {step for segment, step in self.segment_mid_of.items() if segment not in self.segment_taper}

    @property
    def gyro_gain(self) -> np.ndarray:
        """(M,) how each step's gyro noise enters the segment's gyro angle: 1, or in a tapered segment its rate
        weight times the segment's length (the gyro mean reads the angle over the length)."""
        gain = np.ones(len(self.step_dt))
        for segment, (steps, weights) in self.segment_taper.items():
            gain[steps] = weights * self.segment_duration[segment]
        return gain

    def quantization_weight(self, segment: int) -> float:
        """What a pulse remainder's variance brings to a segment's gyro mean: ``2 / T^2`` (its ends), or the
        sum of the squared coefficients of the tapered mean on the attitudes after its steps."""
        if segment in self.segment_taper:
            weights = self.segment_taper[segment][1]
            return float(np.sum((weights - np.concatenate([weights[1:], [0.0]])) ** 2))
        return 2.0 / self.segment_duration[segment] ** 2

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
