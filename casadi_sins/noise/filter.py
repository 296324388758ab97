"""The Kalman filter over the noise model, written once as a CasADi step and run compiled.

One pass over a recording's tracks whitens residual columns: each observation's three rows become its
innovation ``e = y - H x`` times ``L^-1`` (``S = L L^T``), and ``sum log det S`` is the likelihood's
determinant.  The model's events are folded into the steps and unobserved steps composed
(:mod:`noise.steps`); the filter visits one row per observation:

:func:`filter_step_function`
    predict with the composed step (nothing for a step's second observation); a *free* velocity offset
    (a rotation's step not used) only sets the offset and restarts the velocity error; else update with
    the velocity observation ``dv + C e_a`` or the gyro mean ``a / T + C_mid^T [w_ie x] phi_mid``.

The step is one CasADi ``Function`` for a block of columns; it runs compiled (:mod:`core.compiled`),
or on CasADi's virtual machine without a C compiler.  Group starts (the biases wander on, the other
states restart) are applied between the tracks' chains.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from ..core.compiled import StepChain
from ..model.noise import SensorNoise
from .observations import ObservationKind
from .statespace import (ACC, DV, GYRO_FLOOR, PHI, PM, VELOCITY_FLOOR, GroupTrack, Layout, Whitened,
                         gauss_markov_integrals)
from .steps import composed_steps, search_key

#: Columns per compiled pass of the filter (more columns: several passes; one column: its own step).
FILTER_COLUMNS = 40


def transition_pattern(layout: Layout) -> np.ndarray:
    """(n, n) bool: where a folded or composed step transition can be nonzero (closed under products)."""
    pattern = np.eye(layout.n, dtype=bool)
    blocks = [(PHI, PHI), (DV, PHI), (PM, PHI)]
    if layout.markov:
        blocks += [(PHI, layout.bg), (ACC, layout.bg), (DV, layout.bg), (PM, layout.bg), (DV, layout.ba)]
    if layout.unmodelled:
        blocks.append((DV, layout.ua))
    for rows, cols in blocks:
        pattern[rows, cols] = True
    return pattern


def _cholesky3(s):
    """Lower Cholesky factor ``(l11, l21, l31, l22, l32, l33)`` of a symmetric positive definite 3 x 3."""
    l11 = ca.sqrt(s[0, 0])
    l21, l31 = s[1, 0] / l11, s[2, 0] / l11
    l22 = ca.sqrt(s[1, 1] - l21 * l21)
    l32 = (s[2, 1] - l31 * l21) / l22
    return l11, l21, l31, l22, l32, ca.sqrt(s[2, 2] - l31 * l31 - l32 * l32)


def _lower_solve(factor, e):
    """``L^-1 e`` for a factor of :func:`_cholesky3` and a 3 x k matrix ``e``."""
    l11, l21, l31, l22, l32, l33 = factor
    z1 = e[0, :] / l11
    z2 = (e[1, :] - l21 * z1) / l22
    return ca.vertcat(z1, z2, (e[2, :] - l31 * z1 - l32 * z2) / l33)


def _data_sizes(n: int, ncol: int, nnz: int) -> list[int]:
    """Packed data of a row: transition nonzeros, Q (lower triangle, column-major), R (3 x 3), flags (velocity,
    free, gyro), the gyro mean's H on the segment's gyro angle and middle attitude (3 x 6), the observation
    of the columns (3 x ncol)."""
    return [nnz, n * (n + 1) // 2, 9, 3, 18, 3 * ncol]


def _split(vector, sizes):
    out, offset = [], 0
    for size in sizes:
        out.append(vector[offset:offset + size])
        offset += size
    return out


def _symmetric(matrix):
    """The symmetric matrix of ``matrix``'s lower triangle (the upper one is never computed)."""
    lower = ca.tril(matrix)
    return lower + ca.tril(lower, False).T


def filter_step_function(n: int, ncol: int, pattern: np.ndarray) -> ca.Function:
    """One row of the filter (module docstring) for ``ncol`` columns: predict, then one observation::

        state = [x (n x ncol), P (n x n), offset (3 x ncol), log det]
        (state, const (unused), data) -> (state next, const, whitened rows (3 x ncol))

    ``data`` as :func:`_data_sizes`, the transition given by the nonzeros of ``pattern`` (column-major).
    The covariance update is ``P - K H P`` (the Joseph form's value for the optimal gain), its lower
    triangle mirrored.
    """
    rows, cols = np.nonzero(pattern)
    sparsity = ca.Sparsity.triplet(n, n, rows.tolist(), cols.tolist())
    state, const = ca.SX.sym("state", n * ncol + n * n + 3 * ncol + 1), ca.SX.sym("const", 1)
    data = ca.SX.sym("data", sum(_data_sizes(n, ncol, sparsity.nnz())))
    x, p, offset, log_det = _split(state, [n * ncol, n * n, 3 * ncol, 1])
    x, p, offset = ca.reshape(x, n, ncol), ca.reshape(p, n, n), ca.reshape(offset, 3, ncol)
    phi, q, r, flags, h_gyro, y = _split(data, _data_sizes(n, ncol, sparsity.nnz()))
    phi, q = ca.SX(sparsity, phi), ca.tril2symm(ca.SX(ca.Sparsity.lower(n), q))
    r, y = ca.reshape(r, 3, 3), ca.reshape(y, 3, ncol)
    is_velocity, free, is_gyro = flags[0], flags[1], flags[2]
    velocity, gyro = ca.SX(3, n), ca.SX(3, n)
    h_gyro = ca.reshape(h_gyro, 3, 6)
    for a in range(3):
        velocity[a, DV.start + a] = 1
        gyro[:, ACC.start + a], gyro[:, PM.start + a] = h_gyro[:, a], h_gyro[:, 3 + a]
    x = phi @ x
    p = _symmetric(phi @ p @ phi.T + q)
    # a free velocity offset: the observation only sets it, and the velocity error restarts at its remainder
    keep = ca.SX.eye(n) - free * (velocity.T @ velocity)
    x = keep @ x
    p = keep @ p @ keep.T + free * (velocity.T @ r @ velocity)
    offset = free * y + (1 - free) * offset
    active = is_velocity * (1 - free) + is_gyro
    h = is_velocity * (1 - free) * velocity + is_gyro * gyro
    ph = p @ h.T
    s = h @ ph + active * r + (1 - active) * ca.SX.eye(3)
    factor = _cholesky3(0.5 * (s + s.T))
    e = active * (y - is_velocity * offset - h @ x)
    log_det = log_det + 2 * (ca.log(factor[0]) + ca.log(factor[3]) + ca.log(factor[5]))
    gain = ph @ ca.inv(s)
    x = x + gain @ e
    p = _symmetric(p - gain @ ph.T)
    state_next = ca.vertcat(ca.vec(x), ca.vec(p), ca.vec(offset), log_det)
    return ca.Function("kalman_step", [state, const, data], [state_next, const, _lower_solve(factor, e)])


@functools.lru_cache(maxsize=16)
def filter_chain(n: int, ncol: int, pattern_bytes: bytes) -> StepChain:
    """:func:`filter_step_function` compiled, as a chain over the observed steps of a track."""
    pattern = np.frombuffer(pattern_bytes, dtype=bool).reshape(n, n)
    return StepChain(f"kalman{n}_{ncol}", f"{n}|{ncol}|{pattern_bytes.hex()}",
                     lambda: filter_step_function(n, ncol, pattern))


class _Rows:
    """A track's rows, as far as they do not depend on the noise levels: one row per observation (in step
    order, a step's velocity before its gyro mean) and one for the track's end when nothing is observed
    there.

    Attributes: ``composed`` the index of each row's composed step among the observed steps (-1: a step's
    second observation, nothing to predict); ``velocity`` and ``gyro`` the rows of each kind; ``free`` which
    velocity rows set a free offset; the gyro rows' ``H`` on the gyro angle and middle attitude, segment
    lengths and sway; each observation's residual rows (K, 3).
    """

    def __init__(self, system, track: GroupTrack, ends: list[int]):
        observations = sorted(track.observations, key=lambda o: (o.step, int(o.kind)))
        steps = np.array([obs.step for obs in observations] + (
            [ends[-1]] if not observations or ends[-1] != observations[-1].step else []), dtype=int)
        self.k = len(steps)
        first = np.concatenate([[True], steps[1:] != steps[:-1]])
        self.composed = np.full(self.k, -1)
        self.composed[first] = np.arange(first.sum())
        kinds = np.array([int(obs.kind) for obs in observations], dtype=int)
        self.velocity = np.flatnonzero(kinds == ObservationKind.VELOCITY)
        self.gyro = np.flatnonzero(kinds == ObservationKind.GYRO_MEAN)
        at = steps[self.velocity]
        self.attitude = track.attitude[at]
        # a free velocity offset from a step on: set by the next velocity observation
        free_so_far = np.cumsum(np.asarray(track.free_velocity, dtype=int))
        self.free = (free_so_far[at] - np.concatenate([[0], free_so_far[at[:-1]]])) > 0
        segments = [observations[i].segment for i in self.gyro]
        self.duration = np.array([track.segment_duration[s] for s in segments])
        self.tapered = np.array([s in track.segment_taper for s in segments], dtype=bool)
        self.quantization_weight = np.array([track.quantization_weight(s) for s in segments])
        self.sway = np.array([np.broadcast_to(track.segment_sway.get(s, 0.0), (3,)) for s in segments]).reshape(-1, 3)
        self.h_gyro = np.zeros((self.k, 3, 6))
        for i, s in zip(self.gyro, segments):
            self.h_gyro[i] = system.gyro_mean_observation(track, s)
        self.residual_rows = np.array([obs.row + np.arange(3) for obs in observations], dtype=int).reshape(-1, 3)

    def noise(self, noise: SensorNoise) -> tuple[np.ndarray, np.ndarray]:
        """``R`` (K, 3, 3) and flags (velocity, free, gyro) (K, 3) of the rows under ``noise``."""
        r, flags = np.tile(np.eye(3), (self.k, 1, 1)), np.zeros((self.k, 3))
        c = self.attitude
        r[self.velocity] = (c * noise.accel_quantization**2) @ np.swapaxes(c, 1, 2) + np.eye(3) * VELOCITY_FLOOR
        flags[self.velocity, 0], flags[self.velocity, 1] = 1.0, self.free
        quantization = np.where(self.tapered[:, None], self.quantization_weight[:, None] * noise.gyro_quantization**2,
                                2.0 * noise.gyro_quantization**2 / self.duration[:, None] ** 2)
        variance = quantization + self.sway + noise.unmodelled_rate**2 + GYRO_FLOOR
        r[self.gyro] = variance[:, :, None] * np.eye(3)
        flags[self.gyro, 2] = 1.0
        return r, flags


def _track_data(system, track: GroupTrack, noise: SensorNoise, layout: Layout, pattern: np.ndarray, ncol: int,
                repeated: bool):
    """The packed data rows of a track (observations zero), the residual rows of its observations (in row
    order), a pad row, and where the observations start in a row."""
    n = layout.n
    ends, phi, q = composed_steps(system, track, noise, layout, repeated)
    if np.abs(phi[:, ~pattern]).max(initial=0.0) > 0.0:
        raise RuntimeError("a step transition outside its sparsity pattern")
    col_of, row_of = np.nonzero(pattern.T)  # the nonzeros in column-major order
    lower_col, lower_row = np.nonzero(np.tril(np.ones((n, n), bool)).T)
    cache = system.track_rows
    if id(track) not in cache:
        cache[id(track)] = _Rows(system, track, ends)
    rows = cache[id(track)]
    composed, (r, flags), k = rows.composed, rows.noise(noise), rows.k
    sizes = _data_sizes(n, ncol, len(row_of))
    data = np.zeros((k, sum(sizes)))
    identity = (row_of == col_of).astype(float)
    parts = [np.where(composed[:, None] >= 0, phi[composed][:, row_of, col_of], identity),
             np.where(composed[:, None] >= 0, q[composed][:, lower_row, lower_col], 0.0),
             np.swapaxes(r, 1, 2).reshape(k, 9), flags, np.swapaxes(rows.h_gyro, 1, 2).reshape(k, 18)]
    offset = 0
    for part, size in zip(parts, sizes):
        data[:, offset:offset + size] = part
        offset += size
    pad = np.zeros(sum(sizes))  # a row that changes nothing: Phi = I, Q = 0, no observation
    pad[:len(row_of)] = identity
    pad[sum(sizes[:2]):sum(sizes[:3])] = np.eye(3).ravel()
    return data, rows.residual_rows, pad, offset


def _start_group(x: np.ndarray, p: np.ndarray, track: GroupTrack, previous_end: float | None, noise: SensorNoise,
                 layout: Layout) -> None:
    """A new group (in place): the biases wander on since the last one; attitude free (estimated), velocity
    zero up to the accelerometers' remainder, the other states restart."""
    if layout.markov and previous_end is not None:
        for sl, sigma, tau in ((layout.bg, noise.gyro_bias_instability, noise.gyro_bias_tau),
                               (layout.ba, noise.accel_bias_instability, noise.accel_bias_tau)):
            beta = gauss_markov_integrals(max(track.start_time - previous_end, 0.0), tau)[0]
            x[sl] *= beta
            p[sl, :] *= beta
            p[:, sl] *= beta
            p[sl, sl] += np.eye(3) * sigma**2 * (1.0 - beta**2)
    for sl in (PHI, DV, ACC, PM) + ((layout.ua,) if layout.unmodelled else ()):
        x[sl] = 0.0
        p[sl, :] = 0.0
        p[:, sl] = 0.0
    c0 = track.attitude[0]
    p[DV, DV] = (c0 * noise.accel_quantization**2) @ c0.T


def whiten(system, columns: np.ndarray, noise: SensorNoise) -> Whitened:
    """``Sigma^-1/2`` applied to residual columns (rows in residual order) under ``noise``: one filter pass
    over ``system``'s tracks (a :class:`noise.kalman.NoiseSystem`), in compiled passes of columns."""
    noise = noise.complete()
    columns = np.asarray(columns, dtype=float)
    columns = columns[:, None] if columns.ndim == 1 else columns
    layout = Layout.of(noise)
    n, total = layout.n, columns.shape[1]
    ncol = 1 if total == 1 else FILTER_COLUMNS
    pattern = transition_pattern(layout)
    chain = filter_chain(n, ncol, pattern.tobytes())
    key = search_key(noise, layout)
    seen = system.whitenings
    seen[key] = seen.get(key, 0) + 1  # from the third whitening on (a likelihood search), from components
    tracks = [_track_data(system, track, noise, layout, pattern, ncol, seen[key] > 2) for track in system.tracks]
    out = np.zeros_like(columns)
    log_det = 0.0
    for c0 in range(0, total, ncol):
        block = columns[:, c0:c0 + ncol]
        width = block.shape[1]
        x, p = np.zeros((n, ncol)), np.zeros((n, n))
        if layout.markov:
            p[layout.bg, layout.bg] = np.eye(3) * noise.gyro_bias_instability**2
            p[layout.ba, layout.ba] = np.eye(3) * noise.accel_bias_instability**2
        previous_end, pass_log_det = None, 0.0
        for track, (data, rows, pad, obs_at) in zip(system.tracks, tracks):
            _start_group(x, p, track, previous_end, noise, layout)
            observed = np.zeros((len(data), ncol, 3))  # per row: the observation, 3 x ncol column-major
            observed[:len(rows), :width] = np.swapaxes(block[rows], 1, 2)
            data[:, obs_at:] = observed.reshape(len(data), -1)
            state = np.concatenate([x.ravel(order="F"), p.ravel(order="F"), np.zeros(3 * ncol), [0.0]])
            result, final = chain(state, np.zeros(1), data, pad)
            out[rows, c0:c0 + width] = np.swapaxes(result.reshape(len(data), ncol, 3)[:len(rows), :width], 1, 2)
            x = final[:n * ncol].reshape(n, ncol, order="F")
            p = final[n * ncol:n * ncol + n * n].reshape(n, n, order="F")
            pass_log_det += final[-1]
            previous_end = track.end_time
        if c0 == 0:
            log_det = pass_log_det
    return Whitened(out, float(log_det), system.rows)
