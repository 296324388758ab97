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
from .analysis import horizontal, velocity
from .covariance import propagate
from .design import (INNER_AXES, PHASES, Request, check_request, choices, error_root, local_search, proxy,
                     step_tables)
from .schemes import Scheme, Step
from .sources import Sources

#: A search space this small is enumerated whole (the single-axis one up to 17 positions).
EXHAUSTIVE = 2**17


@dataclasses.dataclass
class Candidate:
    """One candidate: its inner axis (``()`` for single-axis), choice indices, start phase and figures.

    ``proxy`` is the proxy (m); ``value`` the criterion of the full propagation (m or m/s) once confirmed.
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
    horizontal position error at the end."""
    cov = prop.covariance(sources.initial_covariance)
    if criterion == "velocity":
        return float(velocity(cov).max())
    pos = horizontal(cov)
    return float(pos[-1] if criterion == "final" else pos.max())


def _start_sequences(n_choices: int, positions: int, samples: int, rng) -> np.ndarray:
    """Every sequence when there are few, else ``samples`` random ones."""
    if n_choices**positions <= EXHAUSTIVE:
        return np.array(list(itertools.product(range(n_choices), repeat=positions)))
    return rng.integers(0, n_choices, (samples, positions))


def _candidates(req: Request, sources: Sources, site: Site, samples: int, starts: int, seed: int,
                progress: Callable[[str], None]) -> tuple[list[Candidate], int]:
    """The proxy's best candidates of every inner axis and start phase, and how many were scored."""
    root = error_root(sources)
    pool, scored = [], 0
    for axes in INNER_AXES[req.axes]:
        tables = step_tables(req, site, axes, root)
        n_choices = len(tables.choices)

        def score(s, tables=tables):
            return proxy(s, tables, req, site)

        seqs = _start_sequences(n_choices, req.positions, samples, np.random.default_rng(seed))
        values = score(seqs)
        scored += len(seqs)
        order = np.argsort(values)[:starts]
        order = order[np.isfinite(values[order])]
        minima, count = local_search(seqs[order], score, n_choices)
        scored += count
        label = "+".join(("z",) + axes)
        progress(f"axes {label}: {len(seqs)} start sequences, local search scored {count} more; best proxy "
                 f"{score(minima).min():.1f} m")
        for seq in {tuple(s) for s in np.concatenate([minima, seqs[order]])}:
            for phase in PHASES:
                dwell0 = phase * req.stop
                pool.append(Candidate(axes, seq, dwell0, float(proxy(np.array([seq]), tables, req, site, dwell0)[0])))
    return sorted(pool, key=lambda c: c.proxy), scored


def design(req: Request, sources: Sources, site: Site, samples: int = 20000, starts: int = 12,
           confirm: int = 24, seed: int = 0, progress: Callable[[str], None] = lambda msg: None) -> Design:
    """Search rotation sequences for the smallest ``req.criterion`` of the covariance.

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
    pool, scored = _candidates(req, sources, site, samples, starts, seed, progress)
    cache: dict = {}
    confirmed = pool[:confirm]
    for k, cand in enumerate(confirmed, start=1):
        prop = propagate(to_scheme(cand, req, "candidate"), site, req.hours, sources.gyro_arw, sources.accel_vrw,
                         cache=cache)
        cand.value = criterion_value(prop, sources, req.criterion)
        if k % 8 == 0 or k == len(confirmed):
            best = min(c.value for c in confirmed[:k])
            progress(f"confirmed {k}/{len(confirmed)} by the full covariance propagation; best {best:.4g} "
                     f"({time.perf_counter() - t0:.1f} s)")
    best = min(confirmed, key=lambda c: c.value)
    name = f"designed-{req.positions}"
    text = (f"Designed by casadi-sins design-scheme for the {req.criterion} criterion over {req.hours:g} h at "
            f"latitude {math.degrees(site.latitude):g} deg, errors {sources.name}: {best.notation()}, "
            f"{math.degrees(req.rate):g} deg/s, {req.stop:g} s per stop, first turn after {best.dwell0:g} s.")
    return Design(req, best, to_scheme(best, req, name, text), sorted(confirmed, key=lambda c: c.value), scored,
                  time.perf_counter() - t0)
