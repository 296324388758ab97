"""Rough sensor models from a session's own rests and moves: the start of a calibration by hand.

Nothing is assumed of the pulses (raw counts with an ADC's mid-scale offset, any size):

* **Accelerometers** (:func:`fit_accelerometers`): at rest the specific force has the magnitude of gravity,
  ``|K_a^-1 (S_a n / dt - B_a)| = g`` for each rest's mean pulses per sample ``n`` (eq. 1): the rests' means
  lie on an ellipsoid.  An algebraic fit of an axis-aligned ellipsoid (linear least squares) gives biases
  and scale factors, a nonlinear least-squares fit of all nine (scipy) adds the misalignments (six with
  fewer than :data:`MISALIGNMENT_RESTS` rests).  The fitted model gives each rest's gravity direction.
* **Gyros** (:func:`fit_gyros`): each rest's mean rate is its bias (the Earth rate is left in: it is far
  below a bias the offsets make); a move's pulses less the mean of the rests on either side, times
  ``M = K_g^-1 diag(S_g)``, integrated sample by sample, must turn the gravity direction of the rest before
  into that of the rest after.  A search over one common pulse size, then Gauss-Newton over the nine
  entries of ``M`` (the attitude's sensitivity to ``M`` carried along the move), give the gyro scale
  factors and misalignments.  What a move cannot show (its turn about gravity) is left to the calibration.

:func:`data.handling.fit_session` turns what the fits find into the one-line refusals of a session that
cannot be calibrated: too few rests, rests that span too few directions, moves too fast for the sample rate.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.earth import EARTH_RATE
from ..core.rotations import rotation_matrices
from ..model.registry import (ACCEL_BIAS, ACCEL_MISALIGN, ACCEL_MISALIGN_ENTRIES, ACCEL_SCALE, GYRO_BIAS,
                              GYRO_MISALIGN, GYRO_MISALIGN_ENTRIES, GYRO_SCALE, N_PARAMS, NAMES)

#: Rests the accelerometers' nine parameters need; with fewer the misalignments stay 0 (six parameters), and with
#: more too when the nine-parameter problem's smallest singular value is under this share of its largest (rests
#: along the body axes alone show no misalignment).
MISALIGNMENT_RESTS = 12
MISALIGNMENT_CONDITION = 1e-4
#: The algebraic ellipsoid is taken when its smallest singular value stands this far below the next one.
ALGEBRAIC_SEPARATION = 0.1
#: The accelerometers' offsets and scales are determined by the rests when, under a specific-force noise of this
#: share of gravity per sample (a generous MEMS one), their uncertainty stays under this share (of g; relative).
REST_NOISE = 1e-3
DETERMINED = 0.01
#: Fewest rests of a session by hand: the accelerometers' nine parameters from gravity's magnitude alone need
#: nine, and IMU-TK (Tedaldi et al. 2014) asks for at least twelve; its protocol has 30-40.
MIN_HAND_RESTS = 12
#: The rests' gravity directions must span more than this (deg): within it the ellipsoid of the accelerometers
#: is a cap, its centre (the biases) and axes (the scale factors) undetermined.
MIN_SPREAD_DEG = 30.0
#: A move that turns more than this in one sample (deg) is too fast for the sample rate: the sample-by-sample
#: navigation of the calibration (its coning terms) is no longer a small-angle step.
MAX_STEP_DEG = 15.0
#: A move whose gravity the first fit misses by more than this many times the median miss (and this many degrees)
#: is left out of the second.
OUTLIER_MISS = 5.0
OUTLIER_MISS_DEG = 3.0
#: Samples whose pulses are summed in the search for the gyros' common pulse size (then half as many), and in the
#: Gauss-Newton fit of ``M``, which stops when its steps are below this share of the size.
SEARCH_BLOCK = 4
FIT_BLOCK = 2
FIT_TOLERANCE = 1e-5
#: Resting gyro rates this many times the Earth rate are a bias (a MEMS unit): the rough bias is the rests' mean.
BIAS_EARTH_RATIO = 10.0


@dataclasses.dataclass(frozen=True)
class AccelFit:
    """The accelerometers' rough model: scale factors (m/s per pulse), biases (m/s^2), the misalignments of
    :data:`model.registry.ACCEL_MISALIGN_ENTRIES` (rad), each rest's gravity direction in the body (unit,
    up), and the rms misfit of the rests' specific force against gravity (m/s^2)."""

    scale: np.ndarray
    bias: np.ndarray
    misalignment: np.ndarray
    up: np.ndarray
    misfit: float

    def force(self, means: np.ndarray, dt: float) -> np.ndarray:
        """Specific force (m/s^2, body) of mean pulses per sample, rows."""
        return (np.linalg.solve(_lower(self.misalignment), (means * self.scale / dt - self.bias).T)).T


@dataclasses.dataclass(frozen=True)
class GyroFit:
    """The gyros' rough model: ``M = K_g^-1 diag(S_g)`` (rad per pulse), the biases (pulses per sample: the
    rests' mean), each move's miss (deg: the angle between the gravity direction the gyros carry into the next
    rest and the measured one), and its largest turn in one sample (deg)."""

    matrix: np.ndarray
    bias_pulses: np.ndarray
    miss_deg: np.ndarray
    step_deg: np.ndarray

    @property
    def scale(self) -> np.ndarray:
        """``S_g`` (rad per pulse)."""
        return 1.0 / np.diag(np.linalg.inv(self.matrix))

    @property
    def misalignment_matrix(self) -> np.ndarray:
        """``K_g = diag(S_g) M^-1`` (unit diagonal)."""
        return np.diag(self.scale) @ np.linalg.inv(self.matrix)


def _lower(misalignment) -> np.ndarray:
    k = np.eye(3)
    for value, (i, j) in zip(misalignment, ACCEL_MISALIGN_ENTRIES):
        k[i, j] = value
    return k


def _algebraic_ellipsoid(means: np.ndarray, g: float, dt: float):
    """Scale factors and biases of an axis-aligned ellipsoid through the means (``a n^2 + c n + e = 0``, the
    smallest singular vector), or None when the rests do not single one out (fewer than seven, a second
    solution as good: rests along the axes only)."""
    design = np.column_stack([means**2, means, np.ones(len(means))])
    norm = np.linalg.norm(design, axis=0)
    if len(means) < 7 or np.any(norm == 0):
        return None
    _, s, vt = np.linalg.svd(design / norm, full_matrices=False)
    if s[-1] > ALGEBRAIC_SEPARATION * s[-2]:
        return None
    coef = vt[-1] / norm
    a, c, e = coef[:3], coef[3:6], coef[6]
    if np.all(a < 0):
        a, c, e = -a, -c, -e
    if not np.all(a > 0):
        return None
    centre = -c / (2.0 * a)
    radius = float(np.sum(a * centre**2) - e)
    if radius <= 0:
        return None
    scale = g * dt * np.sqrt(a / radius)
    return scale, scale * centre / dt


def _magnitude_start(means: np.ndarray, g: float, dt: float):
    """Scale factors with ``|S n| = g dt`` over the rests, no bias (the paper's rough values), or None."""
    design = means**2
    if np.linalg.matrix_rank(design) < 3:
        return None
    u = np.linalg.lstsq(design, np.full(len(means), (g * dt) ** 2), rcond=None)[0]
    return (np.sqrt(u), np.zeros(3)) if np.all(u > 0) else None


def fit_accelerometers(means: np.ndarray, weights: np.ndarray, g: float, dt: float) -> AccelFit:
    """The accelerometers' model from the rests' mean pulses per sample (module docstring).

    Biases and scale factors first, from the algebraic ellipsoid or, when the rests do not single one out,
    from gravity's magnitude without bias; then the misalignments too when the rests determine them (the
    nine-parameter problem's conditioning: rests only along the body axes leave them at 0).

    Parameters
    ----------
    means : ndarray (K, 3)
    weights : ndarray (K,)
        Each rest's weight (its samples' square root).
    g : float
    dt : float

    Raises
    ------
    ValueError
        When the rests do not determine an ellipsoid (too few, or all in one small cap).
    """
    from scipy.optimize import least_squares  # noqa: PLC0415 (scipy's optimiser only for a session by hand)

    means, weights = np.asarray(means, float), np.asarray(weights, float)
    starts = [x for x in (_algebraic_ellipsoid(means, g, dt), _magnitude_start(means, g, dt)) if x is not None]
    if not starts or len(means) < 6:
        raise ValueError("the rests' accelerometer means do not lie on an ellipsoid")

    def solve(scale0, bias0, count):
        def model(x):
            scale = scale0 * (1.0 + x[:3])
            bias = bias0 + g * x[3:6]
            k = _lower(x[6:9] if count == 9 else np.zeros(3))
            return scale, bias, np.linalg.solve(k, (means * scale / dt - bias).T).T

        def residuals(x):
            return weights * (np.linalg.norm(model(x)[2], axis=1) - g) / g

        solution = least_squares(residuals, np.zeros(count), method="trf", loss="soft_l1",
                                 f_scale=0.01 * float(np.median(weights)), x_scale=np.full(count, 1e-2))
        return solution, model(solution.x)

    # a fit that puts every rest's force in one direction (a tiny scale, gravity in the bias) is degenerate
    fits = [f for f in (solve(scale0, bias0, 6) for scale0, bias0 in starts)
            if np.all(f[1][0] > 0) and spread_deg(_unit(f[1][2])) >= MIN_SPREAD_DEG]
    if not fits:
        raise ValueError("the rests' accelerometer means do not lie on an ellipsoid")
    solution, (scale, bias, force) = min(fits, key=lambda f: f[0].cost)
    # rests in one cap fit any of a family of ellipsoids: their offsets and scales are not determined
    try:
        spread = np.sqrt(np.diag(np.linalg.inv(solution.jac.T @ solution.jac))) * REST_NOISE
    except np.linalg.LinAlgError:
        spread = np.full(6, np.inf)
    if not np.all(spread < DETERMINED):
        raise ValueError("the rests' accelerometer means do not determine the ellipsoid")
    if len(means) >= MISALIGNMENT_RESTS:
        wide, wide_model = solve(scale, bias, 9)
        singular = np.linalg.svd(wide.jac, compute_uv=False)
        if singular[-1] > MISALIGNMENT_CONDITION * singular[0]:
            solution, (scale, bias, force) = wide, wide_model
    misfit = float(np.sqrt(np.mean((np.linalg.norm(force, axis=1) - g) ** 2)))
    misalignment = solution.x[6:9] if len(solution.x) == 9 else np.zeros(3)
    return AccelFit(scale, bias, misalignment, _unit(force), misfit)


def _unit(rows: np.ndarray) -> np.ndarray:
    return rows / np.maximum(np.linalg.norm(rows, axis=1, keepdims=True), 1e-300)


def spread_deg(up: np.ndarray) -> float:
    """The largest angle (deg) between two of the gravity directions ``up`` (K, 3)."""
    cos = np.clip(up @ up.T, -1.0, 1.0)
    return float(np.degrees(np.arccos(cos.min()))) if len(up) > 1 else 0.0


def _moves(gyro: np.ndarray, rests, bias_pulses: np.ndarray):
    """Each move's pulses less its bias (the mean of the rests on either side), padded to one length:
    (moves, longest, 3), and the moves' lengths."""
    spans = [(rests[k][1], rests[k + 1][0]) for k in range(len(rests) - 1)]
    longest = max([b - a for a, b in spans], default=0)
    out = np.zeros((len(spans), longest, 3))
    for m, (a, b) in enumerate(spans):
        out[m, :b - a] = gyro[a:b] - 0.5 * (bias_pulses[m] + bias_pulses[m + 1])
    return out, np.array([b - a for a, b in spans])


def _summed(pulses: np.ndarray, block: int) -> np.ndarray:
    """The moves' pulses summed over ``block`` samples: (moves, ceil(L / block), 3)."""
    moves, length, _ = pulses.shape
    padded = np.zeros((moves, -(-length // block) * block, 3))
    padded[:, :length] = pulses
    return padded.reshape(moves, -1, block, 3).sum(axis=2)


def _carry(pulses: np.ndarray, matrices: np.ndarray, sensitivity: bool = False):
    """The rotation of each move (body at its start to body at its end) for each candidate ``M``:
    ``pulses`` (moves, L, 3), ``matrices`` (C, 3, 3) -> (C, moves, 3, 3); with ``sensitivity`` (one ``M``)
    also ``Q[m, :, a, b] = sum_j R_1..j[:, a] r_j[b]`` (moves, 3, 3, 3)."""
    count, moves = len(matrices), len(pulses)
    turn = np.broadcast_to(np.eye(3), (count, moves, 3, 3)).copy()
    q = np.zeros((moves, 3, 3, 3)) if sensitivity else None
    for j in range(pulses.shape[1]):
        r = pulses[:, j]  # (moves, 3)
        theta = np.einsum("cab,mb->cma", matrices, r)
        turn = turn @ rotation_matrices(theta)
        if sensitivity:
            q += turn[0][:, :, :, None] * r[:, None, None, :]
    return turn, q


def _misses(turn: np.ndarray, up: np.ndarray) -> np.ndarray:
    """``R_m^T u_m - u_{m+1}`` for each candidate and move: (C, moves, 3)."""
    return np.einsum("cmji,mj->cmi", turn, up[:-1]) - up[1:]


def _miss_deg(pulses: np.ndarray, matrix: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Per move, the angle (deg) between the gravity direction the gyros carry into the next rest and the measured."""
    carried = np.einsum("mji,mj->mi", _carry(pulses, matrix[None])[0][0], up[:-1])
    return np.degrees(np.arccos(np.clip(np.sum(carried * up[1:], axis=1), -1.0, 1.0)))


def _gauss_newton(paired: np.ndarray, up: np.ndarray, best: float, kept: np.ndarray, iterations: int,
                  start: np.ndarray | None = None) -> np.ndarray:
    """Gauss-Newton over the nine entries of ``M`` on the ``kept`` moves (pulses summed in pairs), from ``best``
    times the identity (or ``start``): the attitude's sensitivity to ``M`` carried along each move."""
    matrix = best * np.eye(3) if start is None else start
    prior = 0.3 * best  # a weak prior on M about the common size: a direction no move shows stays near it
    paired, up_before, up_after = paired[kept], up[:-1][kept], up[1:][kept]
    for _ in range(iterations):
        turn, q = _carry(paired, matrix[None], sensitivity=True)
        turn = turn[0]
        v = np.einsum("mji,mj->mi", turn, up_before)  # R^T u
        miss = v - up_after
        phi = np.einsum("mji,mjab->miab", turn, q).reshape(len(v), 3, 9)  # R^T Q
        jac = np.cross(v[:, :, None], phi, axis=1)  # d(miss)/d(M entries): [v x] phi
        a = jac.reshape(-1, 9)
        rhs = -miss.ravel()
        a = np.vstack([a, np.eye(9) * (1.0 / prior) * 1e-3])
        rhs = np.concatenate([rhs, -(matrix - best * np.eye(3)).ravel() * (1.0 / prior) * 1e-3])
        step = np.linalg.lstsq(a, rhs, rcond=None)[0].reshape(3, 3)
        trial = matrix + step
        new = np.sum((np.einsum("mji,mj->mi", _carry(paired, trial[None])[0][0], up_before) - up_after) ** 2)
        while new > np.sum(miss**2) and np.max(np.abs(step)) > 1e-9 * best:
            step /= 2.0
            trial = matrix + step
            new = np.sum((np.einsum("mji,mj->mi", _carry(paired, trial[None])[0][0], up_before) - up_after) ** 2)
        matrix = trial
        if np.max(np.abs(step)) < FIT_TOLERANCE * best:
            break
    return matrix


def fit_gyros(gyro: np.ndarray, rests, up: np.ndarray, iterations: int = 8) -> GyroFit:
    """The gyros' ``M`` from the moves between consecutive ``rests`` (module docstring).

    Parameters
    ----------
    gyro : ndarray (N, 3)
        Raw pulses.
    rests : list of (int, int)
        The rests, in time order.
    up : ndarray (K, 3)
        Each rest's gravity direction (:attr:`AccelFit.up`).

    Raises
    ------
    ValueError
        When the gyros show no motion between the rests.
    """
    bias = np.array([gyro[a:b].mean(axis=0) for a, b in rests])
    pulses, lengths = _moves(gyro, rests, bias)
    paths = np.linalg.norm(pulses, axis=2).sum(axis=1)
    if not len(paths) or paths.max() <= 0:
        raise ValueError("the gyros show no motion between the rests")
    # one common size: turns of 10 deg to 10 turns along the longest path, coarse then fine, on pulses summed over
    # a few samples (a search for the size needs no coning)
    sizes = np.geomspace(math.radians(10.0) / paths.max(), math.radians(3600.0) / paths.max(), 40)
    for block, count in ((SEARCH_BLOCK, 11), (SEARCH_BLOCK // 2, 0)):
        turn, _ = _carry(_summed(pulses, block), sizes[:, None, None] * np.eye(3))
        cost = np.sum(_misses(turn, up) ** 2, axis=(1, 2))
        best = float(sizes[int(np.argmin(cost))])
        sizes = np.geomspace(best / 1.1, best * 1.1, count)
    paired = _summed(pulses, FIT_BLOCK)  # a rough model: pairs of samples (their coning is far below the moves' misses)
    # a move the gyros cannot carry (a jolt, a range exceeded) is left out: judged at the common size, then again
    matrix = best * np.eye(3)
    kept = np.ones(len(paired), bool)
    for attempt in range(2):
        miss = _miss_deg(paired, matrix, up)
        outliers = miss > max(OUTLIER_MISS * float(np.median(miss)), OUTLIER_MISS_DEG)
        if (~outliers).sum() < 3 or (attempt and np.array_equal(~outliers, kept)):
            break
        kept = ~outliers
        matrix = _gauss_newton(paired, up, best, kept, iterations, matrix)
    miss_deg = _miss_deg(pulses, matrix, up)
    step_deg = np.degrees(np.max(np.linalg.norm(np.einsum("ab,mlb->mla", matrix, pulses), axis=2), axis=1))
    weights = np.array([b - a for a, b in rests], dtype=float)
    return GyroFit(matrix, weights @ bias / weights.sum(), miss_deg, step_deg)


def fit_gsensitivity(rates: np.ndarray, force: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(B_g, G)``: the rests' mean rates (K, 3; rad/s, through ``diag(S_g)``) as a bias and a g-sensitivity,
    ``rate = B_g + G f`` (the gyro g-sensitivity group, :mod:`model.groups.gyro_gsens`; the Earth rate, far
    below a MEMS unit's, left in), weighted least squares over the rests (``force`` m/s^2, body)."""
    design = np.column_stack([np.ones(len(force)), force]) * weights[:, None]
    coef = np.linalg.lstsq(design, rates * weights[:, None], rcond=None)[0]  # (4, 3)
    return coef[0], coef[1:].T


def rough_values(accel: AccelFit, gyros: GyroFit, dt: float, rest_gyro: np.ndarray | None = None,
                 rest_force: np.ndarray | None = None, weights: np.ndarray | None = None) -> dict[str, float]:
    """The parameters of the two fits (SI, by name): the 21; when the rests' mean rate dwarfs the Earth rate
    (:data:`BIAS_EARTH_RATIO`, a MEMS unit) the gyro biases are that rate, and with the rests' mean gyro pulses
    per sample ``rest_gyro`` (K, 3), their specific force ``rest_force`` (K, 3) and ``weights``, the biases and
    the gyro g-sensitivity of :func:`fit_gsensitivity`.  Else the gyro biases are 0 (the paper's rough value)."""
    values = np.zeros(N_PARAMS)
    values[ACCEL_SCALE] = accel.scale
    values[ACCEL_BIAS] = accel.bias
    values[ACCEL_MISALIGN] = accel.misalignment
    k_g = gyros.misalignment_matrix
    values[GYRO_SCALE] = gyros.scale
    values[GYRO_MISALIGN] = [k_g[i, j] for i, j in GYRO_MISALIGN_ENTRIES]
    if np.linalg.norm(gyros.matrix @ gyros.bias_pulses) / dt <= BIAS_EARTH_RATIO * EARTH_RATE:
        return dict(zip(NAMES, values))
    values[GYRO_BIAS] = gyros.scale * gyros.bias_pulses / dt
    out = dict(zip(NAMES, values))
    if rest_gyro is not None and len(rest_gyro) >= MISALIGNMENT_RESTS:
        bias, gsens = fit_gsensitivity(rest_gyro * gyros.scale / dt, rest_force, weights)
        out.update(zip(NAMES[GYRO_BIAS], bias))
        out.update({f"gyro_gsens_{i}{j}": float(gsens[a, b]) for a, i in enumerate("xyz") for b, j in enumerate("xyz")})
    return out
