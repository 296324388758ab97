"""The regressors of the extra output-model terms, per navigation step (see :mod:`model.extras`).

They come from neighbouring samples compensated with reference parameters (the extras are small: a
ppm change of the reference changes them by a ppm of a micro-g): ``Q2 = sum a_k^2 dt`` per axis,
``X = sum ((dtheta_k - w_s dt) x dv_k) / dt`` with ``w_s`` the body's rate at rest, the rate change
over a step from the boundary rates ``w(t_k) = (dtheta_k + dtheta_k+1) / (2 dt)``, and the
centripetal sums ``M``.  Static blocks stay exact: at rest ``X``, ``dw`` and ``M`` vanish up to the
Earth rate and ``Q2`` is a sum over the block's samples.
"""

from __future__ import annotations

import numpy as np

from ...core.rotations import rotation_matrices
from ...data.recording import Recording
from ...model.extras import DW, N_REGRESSORS, Q2, X
from ...model.output import compensate
from ...model.registry import N_PARAMS


def sample_regressors(gyro: np.ndarray, accel: np.ndarray, reference: np.ndarray, dt: float,
                      static_rate: np.ndarray | None = None) -> np.ndarray:
    """Per-sample regressors (N, 15) of a recording's samples, and the boundary rates (N + 1, 3).

    Returns ``(per_sample, boundary_rate)``: ``per_sample`` holds Q2, X, 0 (the dw slot) and M of each
    sample; ``boundary_rate[k]`` is the rate at the start of sample ``k`` (``N``: the end).
    ``static_rate`` (N, 3) is the rate each sample's body has at rest (Earth rate and bias), taken out
    of the time-offset regressor.
    """
    dtheta, dv = compensate(gyro, accel, reference[:N_PARAMS], dt)
    w = dtheta / dt
    out = np.zeros((len(dtheta), N_REGRESSORS))
    out[:, Q2] = dv**2 / dt
    turn = dtheta if static_rate is None else dtheta - static_rate * dt
    out[:, X] = np.cross(turn, dv) / dt
    sq = np.sum(w * w, axis=1)
    out[:, 9] = (w[:, 0] ** 2 - sq) * dt
    out[:, 10] = (w[:, 1] ** 2 - sq) * dt
    out[:, 11] = (w[:, 2] ** 2 - sq) * dt
    out[:, 12] = w[:, 0] * w[:, 1] * dt
    out[:, 13] = w[:, 0] * w[:, 2] * dt
    out[:, 14] = w[:, 1] * w[:, 2] * dt
    padded = np.vstack([w[:1], w, w[-1:]])
    boundary = 0.5 * (padded[:-1] + padded[1:])
    return out, boundary


def static_rates(rec: Recording, reference: np.ndarray) -> np.ndarray:
    """(N, 3) the body rate each sample would have at rest (Earth rate and bias, body frame).

    In a static segment: its mean compensated rate.  Between static segments the body turns, and the
    rate at rest turns with it: the previous segment's mean, rotated back by the angle turned since
    (the accumulated increments less the rate at rest: exact for turns about one axis).
    """
    dtheta_all, _ = compensate(rec.gyro, rec.accel, reference[:N_PARAMS], rec.dt)
    out = np.zeros((len(rec.time), 3))
    for group in rec.group_ids:
        span = rec.group_samples(group)
        cursor, rate = span.start, None
        for seg in rec.group_segments(group):
            sl = rec.segment_samples(seg)
            if seg.is_static:
                rate = dtheta_all[sl].mean(axis=0) / rec.dt
                if cursor < sl.start:  # samples between segments before the first static: at rest
                    out[cursor:sl.start] = rate
                out[sl] = rate
                cursor = sl.stop
                continue
            stop = sl.stop
            turned = np.cumsum(dtheta_all[cursor:stop] - rate * rec.dt, axis=0)
            out[cursor:stop] = np.einsum("nji,j->ni", rotation_matrices(turned), rate)
            cursor = stop
        if cursor < span.stop:
            out[cursor:span.stop] = rate
    return out


def step_regressors(per_sample: np.ndarray, boundary_rate: np.ndarray, first: np.ndarray,
                    stop: np.ndarray) -> np.ndarray:
    """Regressors (15, M) of steps covering samples ``first[j]:stop[j]``."""
    cumulative = np.vstack([np.zeros(N_REGRESSORS), np.cumsum(per_sample, axis=0)])
    out = (cumulative[stop] - cumulative[first]).T
    out[DW] = (boundary_rate[stop] - boundary_rate[first]).T
    return out
