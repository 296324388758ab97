"""Designing a rotation scheme: search the sequences of 180 deg turns for the smallest navigation error.

A candidate is ``N`` steps, each a 180 deg turn about one IMU axis (z; with two axes also y or x: the
inner axis is searched too) in either sense, then a stop; and a start phase (the still time before the
first turn).  After a 180 deg turn about a body axis the IMU's axes are again along the ENU axes, so every
candidate visits only four attitudes (``I, R_x, R_y, R_z``: a Klein four-group, ``R_a R_b = R_{a xor b}``
with x, y, z = 1, 2, 3) and only ``4 x 2 x axes`` different steps exist.  Their moments
(:func:`tilt.piece_moments`) are computed once; a candidate's proxies are then sums over its steps:

* the period-mean tilt (:mod:`.tilt`), ``(1/T) sum_j [(N-1-j) L G_j + W_j]`` for steps of length ``L``,
  which sets the Schuler swing ``2 R x tilt``;
* the residual drift ``sum_j G_j / T`` (:mod:`.residual`), which ramps over the run.

Both weighted by the covariance of the sensor errors (``||M S||_F`` with ``S S^T = P``) give the proxy.
The best candidates of a random start and a local search (one or two steps changed at a time) are then
confirmed by the full covariance propagation (:func:`covariance.propagate`, the pieces' discretisation
shared), and the best by the chosen criterion is the design.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

from ...core import units
from ...core.earth import Site
from ...core.errors import InputError
from ..choices import SCHEME_CRITERIA
from . import model as M
from .covariance import check_run
from .schemes import Scheme, Step, still, turn
from .sources import Sources
from .tilt import mean_radius, piece_moments

CRITERIA = SCHEME_CRITERIA
#: Start phases tried: the still time before the first turn, as fractions of a stop.
PHASES = (0.0, 0.25, 0.5, 0.75, 1.0)
AXIS_BIT = {"x": 1, "y": 2, "z": 3}
INNER_AXES = {1: ((),), 2: (("y",), ("x",))}
MAX_POSITIONS = 64


@dataclasses.dataclass(frozen=True)
class Request:
    """What to design (SI).

    Attributes
    ----------
    positions : int
        Stops per period (one 180 deg turn before each).
    axes : int
        1 (the vertical IMU axis z alone) or 2 (z and a horizontal IMU axis, y or x, both searched).
    rate, stop, hours : float
        Turn rate (rad/s), stop length (s), length of the run (h).
    criterion : str
        ``position`` (largest horizontal position error of the run), ``velocity`` (largest horizontal
        velocity error) or ``final`` (horizontal position error at the end of the run).
    """

    positions: int
    axes: int
    rate: float
    stop: float
    hours: float
    criterion: str = "position"

    @property
    def step_s(self) -> float:
        """Length of one step (turn and stop), s."""
        return math.pi / self.rate + self.stop


def check_request(req: Request, sources: Sources, site: Site) -> None:
    """Refuse a request no closed scheme can meet, or errors with nothing to design for.

    Raises
    ------
    InputError
        One line naming the value at fault.
    """
    if req.axes not in INNER_AXES:
        raise InputError(None, f"--axes must be 1 or 2 (got {req.axes})")
    if not 2 <= req.positions <= MAX_POSITIONS:
        raise InputError(None, f"--positions must be 2 to {MAX_POSITIONS} (got {req.positions})")
    if req.positions % 2:
        raise InputError(None, f"{req.positions} positions cannot return to the start attitude: with 180 deg turns "
                         "every axis must turn an even number of times (give an even --positions)")
    for what, value in (("--rate-deg-s", req.rate / units.DEG), ("--stop-s", req.stop), ("--hours", req.hours)):
        if not (math.isfinite(value) and value > 0):
            raise InputError(None, f"{what} must be a positive number (got {value:g})")
    if req.rate / units.DEG > 1000.0:
        raise InputError(None, f"--rate-deg-s {req.rate / units.DEG:g} is more than 1000 deg/s: no turntable turns so")
    if req.criterion not in CRITERIA:
        raise InputError(None, f"--criterion must be one of {', '.join(CRITERIA)} (got {req.criterion})")
    if req.hours * 3600.0 < req.positions * req.step_s:
        raise InputError(None, f"the run ({req.hours:g} h) is shorter than one period ({req.positions} x "
                         f"{req.step_s:g} s): nothing to average")
    sensor = sources.p0[M.N_NAV:, M.N_NAV:]
    if not np.any(np.diag(sensor) > 0):
        raise InputError(sources.origin or sources.name, "the errors have no gyro or accelerometer terms: there is "
                         "nothing for a rotation scheme to modulate (give bias, scale or misalignment sigmas)")
    check_run(Scheme("candidate", (Step("z", math.pi, req.rate, req.stop),) * req.positions, np.eye(3)),
              site, req.hours, 60.0)


def choices(axes: tuple[str, ...]) -> list[tuple[str, int]]:
    """The step choices ``(axis, sense)`` of a candidate: z+ z- then the inner axis's."""
    return [(a, s) for a in ("z",) + axes for s in (1, -1)]


def attitude(index: int) -> np.ndarray:
    """The attitude ``C_b^n`` of group element ``index`` (0 = ENU, 1-3 = 180 deg about x, y, z)."""
    return np.diag([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]][index]).astype(float)


@dataclasses.dataclass
class Tables:
    """The moments of every possible step, weighted by the errors' square root ``S`` (``S S^T = P``).

    ``gyro``, ``first``, ``accel``: (4, C, 3, K) per (attitude, choice): ``G S``, ``W S``, ``A S``;
    ``g0``, ``a0``: (3, K) per second still at the start; ``bits``: (C,) group element of each choice.
    """

    choices: list
    gyro: np.ndarray
    first: np.ndarray
    accel: np.ndarray
    g0: np.ndarray
    a0: np.ndarray
    bits: np.ndarray


def error_root(sources: Sources) -> np.ndarray:
    """``S`` (n, K) with ``S S^T`` the sensor errors' covariance (its non-zero eigen-directions)."""
    lam, vec = np.linalg.eigh(sources.p0[M.N_NAV:, M.N_NAV:])
    keep = lam > 1e-12 * lam.max()
    return vec[:, keep] * np.sqrt(lam[keep])


def step_tables(req: Request, site: Site, axes: tuple[str, ...], root: np.ndarray,
                names=M.SHEET_NAMES) -> Tables:
    """The weighted moments of every (attitude, choice) step, and of a still start (per second); ``names`` the
    parameters of the sensor states (:attr:`sources.Sources.names`)."""
    chosen = choices(axes)
    shape = (4, len(chosen), 3, root.shape[1])
    gyro, first, accel = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    for att in range(4):
        for c, (axis, sense) in enumerate(chosen):
            half = turn(0.0, math.pi / req.rate, attitude(att), np.eye(3)[AXIS_BIT[axis] - 1], sense * req.rate)
            g_t, w_t, a_t = piece_moments(half, site, names)
            g_d, w_d, a_d = piece_moments(still(0.0, req.stop, attitude(att ^ AXIS_BIT[axis])), site, names)
            gyro[att, c] = (g_t + g_d) @ root
            first[att, c] = (w_t + req.stop * g_t + w_d) @ root
            accel[att, c] = (a_t + a_d) @ root
    g0, _, a0 = piece_moments(still(0.0, 1.0, attitude(0)), site, names)
    return Tables(chosen, gyro, first, accel, g0 @ root, a0 @ root, np.array([AXIS_BIT[a] for a, _ in chosen]))


def responses(req: Request, site: Site, points: int = 48) -> np.ndarray:
    """(2, T, 4, 3) response of (v_E, v_N, north, east) at ``T`` times over the run to a unit constant tilt
    (first) and a unit constant navigation-frame gyro drift (second), E N U: the static navigation error
    model of :func:`nav.errorstate.navigation_block` (Schuler, Earth-rate and Foucault loops), through
    ``expm([[F, E], [0, 0]] t)`` (the drift enters ``phi' = -drift``)."""
    from ...core.linalg import expm

    model = M.ErrorModel(site, ())
    f = model.navigation[:M.N_NAV, :M.N_NAV]
    big = np.zeros((M.N_NAV + 3, M.N_NAV + 3))
    big[:M.N_NAV, :M.N_NAV] = f
    big[0:3, M.N_NAV:] = -np.eye(3)
    scale = np.array([1.0, 1.0, *model.to_metres()])[:, None]
    schuler = math.pi * math.sqrt(mean_radius(site) / site.g)
    times = np.unique(np.append(np.linspace(0.0, req.hours * 3600.0, points + 1)[1:], schuler))
    times = times[times <= req.hours * 3600.0]
    if req.criterion == "final":
        times = times[-1:]
    out = np.zeros((2, len(times), 4, 3))
    for k, t in enumerate(times):
        ex = expm(big * t)
        out[0, k] = ex[3:7, 0:3] * scale
        out[1, k] = ex[3:7, M.N_NAV:] * scale
    return out


def proxy(seqs: np.ndarray, tables: Tables, req: Request, site: Site, response: np.ndarray,
          dwell0: float = 0.0) -> np.ndarray:
    """Proxy of the criterion of candidate sequences (B, N) of choice indices: the error the period-mean
    tilt and the residual drift alone would cause (``response`` from :func:`responses`), its largest over
    the run (its value at the end for ``final``), summed over the errors by their covariance (m or m/s);
    ``inf`` for a sequence that does not return to its start."""
    b, n = seqs.shape
    length = req.step_s
    att = np.zeros(b, dtype=int)
    tot = np.zeros((b,) + tables.g0.shape)
    gsum, asum = np.zeros_like(tot), np.zeros_like(tot)
    for j in range(n):
        c = seqs[:, j]
        g = tables.gyro[att, c]
        tot += (n - 1 - j) * length * g + tables.first[att, c]
        gsum += g
        asum += tables.accel[att, c]
        att = att ^ tables.bits[c]
    period = n * length
    tot += dwell0 * dwell0 / 2 * tables.g0 + dwell0 * period * tables.g0
    span = period + dwell0
    tilt = -tot / span
    acc = (asum + dwell0 * tables.a0) / span
    tilt[:, 0] += acc[:, 1] / site.g
    tilt[:, 1] -= acc[:, 0] / site.g
    drift = gsum / period
    rows = slice(0, 2) if req.criterion == "velocity" else slice(2, 4)
    x = np.concatenate([tilt, drift], axis=1)  # (B, 6, K)
    gram = (x @ x.transpose(0, 2, 1)).reshape(b, 36)  # sum over the errors of x x^T
    r = np.concatenate([response[0][:, rows], response[1][:, rows]], axis=2)  # (T, 2, 6)
    q = (r.transpose(0, 2, 1) @ r).reshape(len(r), 36)  # |r x|^2 = tr(r^T r x x^T)
    value = np.sqrt(np.clip(gram @ q.T, 0.0, None)).max(axis=1)
    return np.where(att == 0, value, np.inf)


def neighbours(seq: np.ndarray, n_choices: int) -> np.ndarray:
    """Every sequence that differs from ``seq`` in one or two steps."""
    n = len(seq)
    out = []
    for j in range(n):
        for c in range(n_choices):
            if c != seq[j]:
                s = seq.copy()
                s[j] = c
                out.append(s)
                for k in range(j + 1, n):
                    for d in range(n_choices):
                        if d != seq[k]:
                            t = s.copy()
                            t[k] = d
                            out.append(t)
    return np.array(out)


def local_search(seqs: np.ndarray, score: Callable, n_choices: int, rounds: int = 30) -> tuple[np.ndarray, int]:
    """Descend from each sequence to a local minimum of ``score`` (steepest descent over
    :func:`neighbours`); returns the minima and the number of candidates scored."""
    best, count = [], 0
    for seq in seqs:
        value = score(seq[None])[0]
        for _ in range(rounds):
            near = neighbours(seq, n_choices)
            values = score(near)
            count += len(near)
            k = int(np.argmin(values))
            if not values[k] < value * (1 - 1e-9):
                break
            seq, value = near[k], values[k]
        best.append(seq)
    return np.array(best), count
