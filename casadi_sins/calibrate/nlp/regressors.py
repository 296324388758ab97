"""The regressors of the extra output-model terms of a recording (the blocks: :mod:`model.regressors`).

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
from ...model.output import compensate
from ...model.registry import N_PARAMS
from ...model.regressors import boundary_rates, sample_rows


def sample_regressors(gyro: np.ndarray, accel: np.ndarray, reference: np.ndarray, dt: float, blocks,
                      static_rate: np.ndarray | None = None) -> np.ndarray:
    """Per-sample regressors (N, rows) of the given blocks (:mod:`model.regressors`) of a recording's
    samples compensated with ``reference``, and the boundary rates (N + 1, 3).

    ``static_rate`` (N, 3) is the rate each sample's body has at rest (Earth rate and bias), taken out
    of the time-offset regressor.
    """
    dtheta, dv = compensate(gyro, accel, reference[:N_PARAMS], dt)
    return sample_rows(dtheta, dv, dt, blocks, static_rate), boundary_rates(dtheta, dt)


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

