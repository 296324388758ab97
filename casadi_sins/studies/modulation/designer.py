"""The design search of ``casadi-sins design-scheme``: random start, local search on the proxies, start
phases, then the full covariance propagation of the best candidates (:mod:`.design` has the proxies)."""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from typing import Callable

import numpy as np

from ...core.earth import Site
from .covariance import Propagation, discretise
from .design import (AXIS_BIT, INNER_AXES, PHASES, Request, attitude, check_request, choices, error_root,
                     local_search, neighbours, proxy, responses, step_tables)
from .schemes import Scheme, Step, still, turn
from .sources import Sources

#: A search space this small is enumerated whole (the single-axis one up to 17 positions).
EXHAUSTIVE = 2**17


@dataclasses.dataclass
class Candidate:
    """One candidate: its inner axis (``()`` for single-axis), choice indices, start phase and figures.

    ``proxy`` is the criterion the period-mean tilt and the residual drift predict (:func:`design.proxy`);
    ``value`` that of the full propagation (m or m/s) once confirmed.
    """

    axes: tuple
    seq: tuple
    dwell0: float
    proxy: float
    value: float | None = None

    def notation(self) -> str:
        """``z+ y- ...`` of the steps."""
        chosen = choices(self.axes)
        return " ".join(f"{chosen[c][0]}{'+' if chosen[c][1] > 0 else '-'}" for c in self.seq)


@dataclasses.dataclass
class Design:
    """The result of a search: the best candidate as a scheme, every confirmed one, and the effort."""

    request: Request
    best: Candidate
    scheme: Scheme
    confirmed: list[Candidate]
    scored: int
    seconds: float


def to_scheme(cand: Candidate, req: Request, name: str, description: str = "") -> Scheme:
    """A candidate as a scheme (start ENU; 180 deg turns about IMU axes; the start phase as an initial dwell)."""
    chosen = choices(cand.axes)
    steps = tuple(Step(chosen[c][0], chosen[c][1] * math.pi, req.rate, req.stop) for c in cand.seq)
    return Scheme(name, steps, np.eye(3), cand.dwell0, description, "designed")


def criterion_value(prop, sources: Sources, criterion: str) -> float:
    """The criterion of a propagation: largest horizontal position (m) or velocity (m/s) error, or the
    horizontal position error at the end (only the variances are formed: ``diag(S P S^T)`` by a root of P)."""
    lam, vec = np.linalg.eigh(sources.initial_covariance)
    root = vec[:, lam > 0] * np.sqrt(lam[lam > 0])
    var = np.sum((prop.sensitivity @ root) ** 2, axis=-1)
    var = var + np.diagonal(prop.noise["gyro noise"] + prop.noise["accel noise"], axis1=1, axis2=2)
    if criterion == "velocity":
        return float(np.sqrt(var[:, 0] + var[:, 1]).max())
    pos = np.sqrt(var[:, 2] + var[:, 3])
    return float(pos[-1] if criterion == "final" else pos.max())


class StepPropagator:
    """The covariance propagation of :func:`covariance.propagate` for candidates made of 180 deg steps: the
    16 (or 8) possible turns and stops are discretised once (:func:`covariance.discretise`), a candidate
    costs only its products.  Outputs at every turn and stop end; a last step the run cuts is left out."""

    def __init__(self, req: Request, sources: Sources, site: Site, axes: tuple, step_deg: float = 5.0):
        self.req, self.sources, self.site, self.axes = req, sources, site, axes
        self.model = sources.model(site)
        self.args = (self.model, sources.gyro_arw, sources.accel_vrw, step_deg)
        self.noisy = bool(np.any(sources.gyro_arw > 0) or np.any(sources.accel_vrw > 0))
        self.steps, self.starts, self.bits = {}, {}, [AXIS_BIT[a] for a, _ in choices(axes)]
        self.scale = np.array([1.0, 1.0, *self.model.to_metres()])[:, None]

    def _step(self, att: int, c: int) -> tuple:
        """The turn and the stop of choice ``c`` from attitude ``att``, discretised on first use."""
        if (att, c) not in self.steps:
            axis, sense = choices(self.axes)[c]
            half = turn(0.0, math.pi / self.req.rate, attitude(att), np.eye(3)[AXIS_BIT[axis] - 1],
                        sense * self.req.rate)
            stop = still(0.0, self.req.stop, attitude(att ^ self.bits[c]))
            self.steps[(att, c)] = ((discretise(half, *self.args), half.duration),
                                    (discretise(stop, *self.args), stop.duration))
        return self.steps[(att, c)]

    def _period(self, seq) -> list:
        """``((Phi, Q_g, Q_a), duration)`` of the pieces of one period from the start attitude."""
        out, att = [], 0
        for c in seq:
            out.extend(self._step(att, c))
            att ^= self.bits[c]
        return out

    def propagate(self, cand: Candidate) -> Propagation:
        """The sensitivities (and noise covariances) of one candidate over the run: one period's partial
        products, then a product per period (the candidate returns to its start)."""
        period, rows, n = self._period(cand.seq), slice(3, 7), self.model.n_state
        if cand.dwell0 not in self.starts:
            self.starts[cand.dwell0] = (discretise(still(0.0, cand.dwell0, attitude(0)), *self.args)
                                        if cand.dwell0 > 0 else (np.eye(n), np.zeros((n, n)), np.zeros((n, n))))
        start = self.starts[cand.dwell0]
        pieces = ([(start, cand.dwell0)] if cand.dwell0 > 0 else []) + period
        partial, acc = [], np.eye(n)
        for (phi, _, _), _length in period:
            acc = phi @ acc
            partial.append(acc[rows] * self.scale)
        stacked, lengths = np.concatenate(partial), np.array([length for _, length in period])
        end, t0, a = self.req.hours * 3600.0 + 1e-6, cand.dwell0, start[0]
        times, sens = [0.0] + ([cand.dwell0] if cand.dwell0 > 0 else []), [np.eye(n)[rows] * self.scale]
        if cand.dwell0 > 0:
            sens.append(a[rows] * self.scale)
        while t0 + lengths[0] <= end:
            ends = t0 + np.cumsum(lengths)
            keep = int(np.searchsorted(ends, end, side="right"))
            sens.extend((stacked @ a).reshape(len(period), 4, n)[:keep])
            times.extend(ends[:keep])
            t0, a = ends[-1], acc @ a
        sens = np.array(sens)
        noise = self._noise(pieces, period, len(times)) if self.noisy else np.zeros((2, len(times), 4, 4))
        return Propagation(np.array(times), sens, {"gyro noise": noise[0], "accel noise": noise[1]})

    def _noise(self, first: list, period: list, count: int) -> np.ndarray:
        """(2, T, 4, 4) covariance of the gyro and the accelerometer noise at the same outputs."""
        n, rows, outer = self.model.n_state, slice(3, 7), self.scale @ self.scale.T
        out, p = np.zeros((2, count, 4, 4)), np.zeros((2, n, n))
        k = 1
        pieces = first + period * count
        while k < count:
            (phi, q_g, q_a), _ = pieces[k - 1]
            p = np.stack([phi @ p[0] @ phi.T + q_g, phi @ p[1] @ phi.T + q_a])
            out[:, k] = p[:, rows, rows] * outer
            k += 1
        return out


def _start_sequences(n_choices: int, positions: int, samples: int, rng) -> np.ndarray:
    """Every sequence when there are few, else ``samples`` random ones."""
    if n_choices**positions <= EXHAUSTIVE:
        return np.array(list(itertools.product(range(n_choices), repeat=positions)))
    return rng.integers(0, n_choices, (samples, positions))


@dataclasses.dataclass
class _Space:
    """One inner axis's search space: its step tables, start sequences and the proxy's responses."""

    axes: tuple
    tables: object
    starts: np.ndarray
    response: np.ndarray

    def score(self, seqs: np.ndarray, req: Request, site: Site, dwell0: float = 0.0) -> np.ndarray:
        """The proxy of sequences (B, N)."""
        return proxy(seqs, self.tables, req, site, self.response, dwell0)


def _spaces(req: Request, sources: Sources, site: Site, samples: int, seed: int) -> list[_Space]:
    """The search spaces of every inner axis."""
    root, response = error_root(sources), responses(req, site)
    out = []
    for axes in INNER_AXES[req.axes]:
        tables = step_tables(req, site, axes, root, sources.names)
        out.append(_Space(axes, tables, _start_sequences(len(tables.choices), req.positions, samples,
                                                         np.random.default_rng(seed)), response))
    return out


def _search(spaces: list[_Space], req: Request, site: Site, starts: int,
            progress: Callable[[str], None]) -> tuple[list[Candidate], int]:
    """Local searches on the proxy from the best start sequences: every minimum at every start phase, best
    proxy first; and how many candidates were scored."""
    pool, scored = [], 0
    for space in spaces:
        def score(s, space=space):
            """The proxy of sequences of this space."""
            return space.score(s, req, site)

        values = score(space.starts)
        order = np.argsort(values)[:starts]
        seeds = space.starts[order[np.isfinite(values[order])]]
        minima, count = local_search(seeds, score, len(space.tables.choices))
        scored += len(space.starts) + count
        progress(f"axes {'+'.join(('z',) + space.axes)}: {len(space.starts)} start sequences, {count} more in "
                 f"{len(seeds)} local searches; best proxy {score(minima).min():.4g}")
        for seq in {tuple(s) for s in np.concatenate([minima, seeds])}:
            for phase in PHASES:
                value = space.score(np.array([seq]), req, site, phase * req.stop)[0]
                pool.append(Candidate(space.axes, seq, phase * req.stop, float(value)))
    return sorted(pool, key=lambda c: c.proxy), scored


def _confirm(cands: list[Candidate], props: dict, sources: Sources, req: Request, done: dict,
             progress: Callable[[str], None], t0: float) -> list[Candidate]:
    """The criterion of every candidate by the full propagation (``done``: (axes, seq, dwell0) ->
    candidate, those already confirmed); returns the confirmed candidates."""
    todo = [c for c in cands if (c.axes, c.seq, c.dwell0) not in done]
    for k, cand in enumerate(todo, start=1):
        if cand.axes not in props:
            props[cand.axes] = StepPropagator(req, sources, props["site"], cand.axes)
        cand.value = criterion_value(props[cand.axes].propagate(cand), sources, req.criterion)
        done[(cand.axes, cand.seq, cand.dwell0)] = cand
    if todo:
        progress(f"confirmed {len(todo)} by the covariance propagation; best so far "
                 f"{min(c.value for c in done.values()):.4g} ({time.perf_counter() - t0:.1f} s)")
    return [done[(c.axes, c.seq, c.dwell0)] for c in cands]


def _polish(best: list[Candidate], spaces: list[_Space], req: Request, site: Site, per_round: int,
            confirm_all: Callable) -> None:
    """Local search on the propagated criterion itself: from each of ``best``, its ``per_round`` closed
    neighbours of best proxy are confirmed, and the search moves while the criterion falls."""
    space_of = {s.axes: s for s in spaces}
    for cand in best:
        space = space_of[cand.axes]
        for _ in range(6):
            near = neighbours(np.array(cand.seq), len(space.tables.choices))
            values = space.score(near, req, site, cand.dwell0)
            order = [k for k in np.argsort(values)[:per_round] if np.isfinite(values[k])]
            trial = confirm_all([Candidate(cand.axes, tuple(near[k]), cand.dwell0, float(values[k])) for k in order])
            step = min(trial, key=lambda c: c.value, default=None)
            if step is None or not step.value < cand.value * (1 - 1e-6):
                break
            cand = step


def design(req: Request, sources: Sources, site: Site, samples: int = 20000, starts: int = 12,
           confirm: int = 60, seed: int = 0, progress: Callable[[str], None] = lambda msg: None) -> Design:
    """Search rotation sequences for the smallest ``req.criterion`` of the covariance.

    Two stages: the proxy (:func:`design.proxy`: the period-mean tilt and the residual drift through the
    static error dynamics) leads a local search from the best of many start sequences, whose best
    ``confirm`` candidates are propagated in full (:class:`StepPropagator`); from the best three, a local
    search on the propagated criterion itself (neighbours ranked by the proxy).

    Parameters
    ----------
    req : Request
    sources : Sources
        The residual errors designed for (a sheet, or a calibrated table's covariance).
    site : Site
    samples : int
        Random start sequences per inner axis (all of them when there are at most :data:`EXHAUSTIVE`).
    starts : int
        Local searches per inner axis, from the best start sequences.
    confirm : int
        Candidates (best proxies, over every start phase) confirmed by the full propagation.
    seed : int
        Of the random start sequences (the search is deterministic).
    progress : callable
        Called with a line of progress at every stage.

    Raises
    ------
    InputError
        When the request cannot be met (:func:`design.check_request`).
    """
    t0 = time.perf_counter()
    check_request(req, sources, site)
    spaces = _spaces(req, sources, site, samples, seed)
    done: dict = {}
    props: dict = {"site": site}

    def confirm_all(cands: list[Candidate]) -> list[Candidate]:
        """Confirm candidates by the full propagation (each once)."""
        return _confirm(cands, props, sources, req, done, progress, t0)

    pool, scored = _search(spaces, req, site, starts, progress)
    confirm_all(pool[:confirm])
    best = sorted(done.values(), key=lambda c: c.value)[:3]
    progress(f"local search on the propagated criterion from the best {len(best)}")
    _polish(best, spaces, req, site, max(8, confirm // 3), confirm_all)
    confirmed = sorted(done.values(), key=lambda c: c.value)
    best = confirmed[0]
    text = (f"Designed by casadi-sins design-scheme for the {req.criterion} criterion over {req.hours:g} h at "
            f"latitude {math.degrees(site.latitude):g} deg, errors {sources.name}: {best.notation()}, "
            f"{math.degrees(req.rate):g} deg/s, {req.stop:g} s per stop, first turn after {best.dwell0:g} s.")
    return Design(req, best, to_scheme(best, req, f"designed-{req.positions}", text), confirmed, scored,
                  time.perf_counter() - t0)
