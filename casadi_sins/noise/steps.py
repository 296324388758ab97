"""The filter's steps: the model's events folded into the transitions, unobserved steps composed.

The events of the noise model are linear maps on the state and covariance, folded into the transition
of the step they precede or follow:

* at a static segment's first step the segment's gyro angle and unmodelled acceleration restart
  (``x <- D x``), the rotation's velocity error and the new unmodelled acceleration enter
  (``P <- D P D^T + P_add``);
* after the segment's middle step its attitude error is kept (``x <- M x``); in a tapered segment
  (:mod:`noise.taper`) the kept attitude error restarts at the segment's start and after every step gains
  the step's weight times the attitude error (``x <- A_k x``, the weighted mean over the steps);

so a step is ``x <- M Phi D x``, ``P <- M (Phi (D P D^T + P_add) Phi^T + Q) M^T``.  Steps without an
observation are composed with the next observed one, and the Kalman filter (:mod:`noise.filter`)
visits only observed steps.  A likelihood search whitens one system again and again under other noise
levels: the step covariances are linear in the variances, so their components are composed once and
only reweighted (:func:`composed_steps`).
"""

from __future__ import annotations

import numpy as np

from ..model.noise import SensorNoise
from .statespace import ACC, DV, PHI, PM, ROTATION_METHOD_ERROR, GroupTrack, Layout, axis_shape


def fold_covariance(track: GroupTrack, layout: Layout, phi: np.ndarray, q: np.ndarray, step_variance: float,
                    unmodelled_variance: float) -> np.ndarray:
    """A step covariance (M, n, n) with the segment starts and middle attitudes folded in (module docstring):
    ``M (Q + Phi P_add Phi^T) M^T``, ``P_add`` the velocity error across a rotation (``step_variance``)
    and the new segment's unmodelled acceleration; ``phi`` unfolded."""
    axes = np.arange(3)
    start = np.asarray(track.segment_start, bool)
    starts = np.flatnonzero(start)
    p_add = np.zeros((len(starts), layout.n, layout.n))
    p_add[np.flatnonzero(starts > 0)[:, None], DV.start + axes, DV.start + axes] = step_variance  # not the first
    if layout.unmodelled:
        p_add[:, layout.ua.start + axes, layout.ua.start + axes] = unmodelled_variance
    q = q.copy()
    q[starts] += phi[starts] @ p_add @ np.swapaxes(phi[starts], 1, 2)
    middle = sorted(track.segment_mid)
    keep = _middle_copy(layout)
    q[middle] = keep @ q[middle] @ keep.T
    if track.segment_taper:  # A q A^T, A = I + W E (E: the attitude error into the kept one)
        steps, weights = _accumulations(track)
        w = weights[:, None, None]
        block = q[steps]
        block[:, PM, :] += w * block[:, PHI, :]
        block[:, :, PM] += w * block[:, :, PHI]
        q[steps] = block
    return q


def fold_transition(track: GroupTrack, layout: Layout, phi: np.ndarray) -> np.ndarray:
    """Step transitions (M, n, n) with the segment starts and middle attitudes folded in: ``M Phi D``."""
    start = np.asarray(track.segment_start, bool)
    restart = np.ones((len(start), layout.n))
    restart[start, ACC] = 0.0
    if layout.unmodelled:
        restart[start, layout.ua] = 0.0
    for steps, _ in track.segment_taper.values():  # a tapered segment's mean attitude error sums from its start
        restart[steps[0], PM] = 0.0
    phi = phi * restart[:, None, :]
    middle = sorted(track.segment_mid)
    phi[middle] = _middle_copy(layout) @ phi[middle]
    if track.segment_taper:  # A Phi, A = I + W E: the kept attitude error gains W times the attitude error
        steps, weights = _accumulations(track)
        phi[steps, PM, :] += weights[:, None, None] * phi[steps, PHI, :]
    return phi


def _accumulations(track: GroupTrack) -> tuple[np.ndarray, np.ndarray]:
    """The steps of the tapered segments and the weight ``W_k = u_k h_k`` with which the kept attitude error gains
    the attitude error after each (``A_k = I + W_k E``)."""
    steps = np.concatenate([s for s, _ in track.segment_taper.values()])
    return steps, np.concatenate([w for _, w in track.segment_taper.values()]) * track.step_dt[steps]


def _middle_copy(layout: Layout) -> np.ndarray:
    """``M``: the attitude error kept as the segment's middle one."""
    keep = np.eye(layout.n)
    keep[PM] = 0.0
    keep[PM.start + np.arange(3), PHI.start + np.arange(3)] = 1.0
    return keep


def fold_events(system, track: GroupTrack, noise: SensorNoise, layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """Every step's folded transition and covariance (M, n, n) under ``noise``."""
    phi, q = system.transitions(track, noise, layout)
    q = fold_covariance(track, layout, phi, q, ROTATION_METHOD_ERROR**2 + noise.unmodelled_step**2,
                        noise.unmodelled_acceleration**2)
    return fold_transition(track, layout, phi), q


def folded_components(system, track: GroupTrack, noise: SensorNoise, layout: Layout):
    """The folded transitions and the covariance as components ``(weights (J,), unit covariances [(M, n, n)])``:
    the transitions' terms (:meth:`noise.kalman.NoiseSystem.covariance_terms`), the velocity error across a
    rotation and, in the layout, the unmodelled acceleration (the transitions do not depend on them)."""
    phi, terms = system.covariance_terms(track, noise, layout)
    zero = np.zeros_like(phi)
    units = [fold_covariance(track, layout, phi, unit, 0.0, 0.0) for _, unit in terms]
    units.append(fold_covariance(track, layout, phi, zero, 1.0, 0.0))
    if layout.unmodelled:
        units.append(fold_covariance(track, layout, phi, zero, 0.0, 1.0))
    return fold_transition(track, layout, phi), component_weights(system, noise, layout), units


def component_weights(system, noise: SensorNoise, layout: Layout) -> np.ndarray:
    """The weights (variances) of :func:`folded_components`' components under ``noise``."""
    weights = system.term_variances(noise, layout) + [ROTATION_METHOD_ERROR**2 + noise.unmodelled_step**2]
    return np.array(weights + ([noise.unmodelled_acceleration**2] if layout.unmodelled else []))


def compose(phi: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One transition and covariance for consecutive steps (K, n, n), composed pairwise (``q`` may hold
    several covariances per step, (K, J, n, n))."""
    phi, q = compose_batch(phi[None], q[None])
    return phi[0], q[0]


def compose_batch(phi: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`compose` of several runs of consecutive steps at once: ``phi`` (B, K, n, n), ``q`` (B, K, n, n) or
    (B, K, J, n, n); returns (B, n, n) and (B, [J,] n, n)."""
    while phi.shape[1] > 1:
        k = phi.shape[1]
        odd = k % 2
        first_phi, first_q = phi[:, 0:k - odd:2], q[:, 0:k - odd:2]
        second_phi, second_q = phi[:, 1::2], q[:, 1::2]
        new_phi = second_phi @ first_phi
        turn = second_phi[:, :, None] if q.ndim == 5 else second_phi  # q per variance component: (B, K, J, n, n)
        new_q = turn @ first_q @ np.swapaxes(turn, -1, -2) + second_q
        if odd:
            new_phi, new_q = np.concatenate([new_phi, phi[:, -1:]], axis=1), np.concatenate([new_q, q[:, -1:]], axis=1)
        phi, q = new_phi, new_q
    return phi[:, 0], q[:, 0]


def observed_steps(system, track: GroupTrack, noise: SensorNoise, layout: Layout, components: bool = False):
    """The track's observed steps (and its last), each with the steps since the previous one composed:
    ``(steps, phi (K, n, n), q (K, n, n))``; with ``components`` ``q`` per component of
    :func:`folded_components`, ``(K, J, n, n)``, and their weights ``(J,)``."""
    if components:
        phi, weights, units = folded_components(system, track, noise, layout)
    else:
        phi, q = fold_events(system, track, noise, layout)
        weights, units = None, [q]
    m = len(phi)
    observed = sorted({obs.step for obs in track.observations})
    ends = np.array(observed + ([m - 1] if m and (not observed or observed[-1] != m - 1) else []), dtype=int)
    starts = np.concatenate([[0], ends[:-1] + 1]).astype(int)
    phis = phi[ends]  # an observed step right after the previous one: nothing to compose
    q_all = units[0] if weights is None else np.stack(units, axis=1)
    qs = q_all[ends]
    lengths = ends - starts + 1
    for length in np.unique(lengths[lengths > 1]):  # runs of one length composed together
        which = np.flatnonzero(lengths == length)
        rows = starts[which][:, None] + np.arange(length)[None, :]
        phis[which], qs[which] = compose_batch(phi[rows], q_all[rows])
    return list(ends), phis, qs, weights


def search_key(noise: SensorNoise, layout: Layout) -> tuple:
    """What a likelihood search keeps while it varies the noise levels: the layout, the correlation times and
    the white noise's proportions between axes (the components depend on these only)."""
    shapes = np.concatenate([axis_shape(noise.gyro_arw), axis_shape(noise.accel_vrw)])
    return layout, noise.gyro_bias_tau, noise.accel_bias_tau, tuple(np.round(shapes, 12))


def composed_steps(system, track: GroupTrack, noise: SensorNoise, layout: Layout, repeated: bool):
    """:func:`observed_steps` under ``noise``; when the system is whitened again and again with the same
    layout and correlation times (a likelihood search), from its variance components, composed once and kept."""
    if not repeated:
        return observed_steps(system, track, noise, layout)[:3]
    key = search_key(noise, layout) + (id(track),)
    cache = system.components
    if key not in cache:
        cache[key] = observed_steps(system, track, noise, layout, components=True)[:3]
    ends, phi, q = cache[key]
    weights = component_weights(system, noise, layout)
    return ends, phi, np.einsum("j,kjab->kab", weights, q)
