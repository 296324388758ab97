"""Bias instability as random effects: the static segments cut into pieces, and the residuals' response
to a bias offset held over each piece.

A Gauss-Markov bias with a correlation time of many minutes is nearly constant over a static segment
and differs between segments.  Held constant over pieces of the static segments (at most ``piece_s``
seconds each; the steps of a rotation join the piece before them), a wander of the six sensor axes
is ``u = L v`` with ``v ~ N(0, I)`` and ``L L^T`` the Gauss-Markov covariance between the pieces, and
the residuals carry ``Z u``: ``Z`` the residuals' response to a unit offset of one axis over one
piece (:func:`bias_responses`).

The responses run through the same steps as the Kalman whitener: :meth:`noise.kalman.NoiseSystem.step_transitions`
with the biases held (``tau = inf``), the model's events folded in (:func:`noise.steps.fold_transition`),
and the same observations (the velocity error, a static segment's gyro mean).  Whitened by the same
filter (:func:`whitened_bias_responses`), they give the restricted likelihood of the wander in closed
form (:mod:`noise.wander`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..model.noise import SensorNoise
from .kalman import ACC, DV, PM, GroupTrack, Layout, NoiseSystem
from .observations import ObservationKind
from .steps import fold_transition

#: The sensors of the bias responses, in column order.
SENSORS = ("accel", "gyro")


@dataclasses.dataclass(frozen=True)
class BiasPiece:
    """One column of the bias responses: a unit offset of one sensor axis over one piece.

    Attributes
    ----------
    sensor : {"accel", "gyro"}
    axis : int
    time : float
        Middle of the piece, s (recording time).
    segment : int
        Its static segment, counted over the recording (``-1 - group``: steps before a group's first one).
    group : int
        Index of its group's track.
    """

    sensor: str
    axis: int
    time: float
    segment: int
    group: int


def track_pieces(track: GroupTrack, piece_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pieces of one group: the piece of every step (M,), the middle time of every piece and its static
    segment counted in the group (-1: the steps before the first).

    Every static segment is cut into equal pieces of at most ``piece_s`` seconds (a step belongs to the
    piece its middle falls in); steps outside static segments join the piece before them.
    """
    ends = track.start_time + np.cumsum(track.step_dt)
    starts = ends - track.step_dt
    segment = np.cumsum(track.segment_start) - 1  # static segment of each step, counted in the group
    static = np.asarray(track.static, bool) & (segment >= 0)
    first = np.flatnonzero(track.segment_start)
    last = np.array([np.flatnonzero(static & (segment == s))[-1] for s in range(len(first))], dtype=int)
    begin, duration = starts[first], ends[last] - starts[first]
    count = np.maximum(1, np.ceil(duration / piece_s - 1e-9).astype(int))
    lead = int(not static[0]) if len(static) else 0  # a piece for the steps before the first static segment
    offset = lead + np.concatenate([[0], np.cumsum(count)[:-1]]).astype(int)
    piece = np.full(len(ends), -1)
    s = segment[static]
    middle = 0.5 * (starts[static] + ends[static]) - begin[s]
    piece[static] = offset[s] + np.minimum((middle / (duration[s] / count[s])).astype(int), count[s] - 1)
    piece = np.maximum.accumulate(np.where(piece >= 0, piece, -1))  # other steps: the piece before them
    piece[piece < 0] = 0
    mids = [starts[0]] * lead + [b + d * (i + 0.5) / c for b, d, c in zip(begin, duration, count) for i in range(c)]
    segments = [-1] * lead + [s for s, c in enumerate(count) for _ in range(c)]
    return piece, np.array(mids, dtype=float), np.array(segments, dtype=int)


def bias_responses(system: NoiseSystem, piece_s: float) -> tuple[np.ndarray, list[BiasPiece]]:
    """The residuals' response (rows in residual order) to a unit offset of each sensor axis held over one
    piece: accelerometers (m/s^2) then gyros (rad/s), each piece by piece and axis by axis.

    Returns ``(Z, pieces)``, ``Z`` (rows, 6 P) and the :class:`BiasPiece` of every column.  An offset
    acts from its piece's start on through the navigation (its velocity and tilt carry on) until the
    group ends; the next group starts afresh, as in the filter.
    """
    plans = [track_pieces(track, piece_s) for track in system.tracks]
    total = sum(len(mids) for _, mids, _ in plans)
    out = np.zeros((system.rows, 6 * total))
    pieces, first, segments = [], 0, 0
    for g, (track, (piece, mids, segs)) in enumerate(zip(system.tracks, plans)):
        count = len(mids)
        columns = (slice(3 * first, 3 * (first + count)), slice(3 * (total + first), 3 * (total + first + count)))
        _track_responses(system, track, piece, count, out, columns)
        pieces.append([(g, float(t), int(segments + seg) if seg >= 0 else -1 - g) for t, seg in zip(mids, segs)])
        first, segments = first + count, segments + int(np.sum(track.segment_start))
    return out, [BiasPiece(sensor, axis, t, seg, g) for sensor in SENSORS for group in pieces
                 for g, t, seg in group for axis in range(3)]


def _track_responses(system: NoiseSystem, track: GroupTrack, piece: np.ndarray, count: int, out: np.ndarray,
                     columns: tuple[slice, slice]) -> None:
    """One group's responses into ``out`` (its accelerometer and gyro ``columns``): the piece offsets switched
    on and off along the folded steps, the steps between two events (a piece's start, an observation)
    applied as one product."""
    layout = Layout(True, False)
    held = SensorNoise(gyro_bias_tau=np.inf, accel_bias_tau=np.inf)
    phi = fold_transition(track, layout, system.step_transitions(track, held, layout))
    starts = np.flatnonzero(np.diff(np.r_[-1, piece]) != 0)
    breaks = np.array(sorted({0, len(phi)} | set(starts.tolist()) | {k + 1 for k in track.observations_at}))
    first, last = breaks[:-1], breaks[1:]
    products = phi[first]  # one step between events: its own transition
    for i in np.flatnonzero(last - first > 1):
        products[i] = _product(phi[first[i]:last[i]])
    switch = np.isin(first, starts).tolist()
    x = np.zeros((layout.n, 6 * count))
    states = np.zeros((len(first), layout.n, 6 * count))
    for i, on in enumerate(switch):
        if on:  # this piece's offsets on, the others off
            col = 3 * piece[first[i]]
            x = x.copy()
            x[layout.ba] = 0.0
            x[layout.bg] = 0.0
            x[layout.ba, col:col + 3] = np.eye(3)
            x[layout.bg, 3 * count + col:3 * count + col + 3] = np.eye(3)
        x = np.matmul(products[i], x, out=states[i])
    at = dict(zip((last - 1).tolist(), range(len(last))))
    velocity = [obs for obs in track.observations if obs.kind == ObservationKind.VELOCITY]
    rows = (np.array([obs.row for obs in velocity], dtype=int)[:, None] + np.arange(3)).ravel()
    values = states[[at[obs.step] for obs in velocity]][:, DV].reshape(len(rows), -1)  # the velocity error
    for obs in track.observations:  # a gyro mean a / T + C_mid^T [w_ie x] phi_mid
        if obs.kind != ObservationKind.VELOCITY:
            x = states[at[obs.step]]
            rows = np.r_[rows, obs.row + np.arange(3)]
            values = np.vstack([values, system.gyro_mean_observation(track, obs.segment) @ np.vstack([x[ACC], x[PM]])])
    out[rows, columns[0]] = values[:, :3 * count]
    out[rows, columns[1]] = values[:, 3 * count:]


def _product(phi: np.ndarray) -> np.ndarray:
    """``Phi_K ... Phi_1`` of consecutive steps (K, n, n), multiplied pairwise."""
    while len(phi) > 1:
        odd = len(phi) % 2
        pairs = phi[1:len(phi) - odd:2] @ phi[0:len(phi) - odd:2]
        phi = np.concatenate([pairs, phi[-1:]]) if odd else pairs
    return phi[0]


def whitened_bias_responses(system: NoiseSystem, noise: SensorNoise, piece_s: float
                            ) -> tuple[np.ndarray, list[BiasPiece]]:
    """:func:`bias_responses` whitened by the Kalman filter under ``noise`` (``Sigma^-1/2 Z``).

    Without Gauss-Markov states in ``noise`` the groups are independent in the filter (every state
    restarts at a group's start) and a piece's response lies in its own group's rows: one column of each
    group shares a filter column, and the rows tell them apart again (the same numbers in fewer passes).
    """
    responses, pieces = bias_responses(system, piece_s)
    if Layout.of(noise).markov or len(system.tracks) == 1:
        return system.whiten(responses, noise).columns, pieces
    group = np.array([p.group for p in pieces])
    members = [np.flatnonzero(group == g) for g in range(len(system.tracks))]
    packed = np.zeros((len(responses), max(len(m) for m in members)))
    for m in members:
        packed[:, :len(m)] += responses[:, m]
    white = system.whiten(packed, noise).columns
    out = np.zeros_like(responses)
    for track, m in zip(system.tracks, members):
        rows = np.concatenate([obs.row + np.arange(3) for obs in track.observations])
        out[np.ix_(rows, m)] = white[rows, :len(m)]
    return out, pieces
