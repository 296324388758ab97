"""Monte Carlo over seeds: simulate, calibrate, collect errors in natural units."""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from . import parameters as P
from .problem import Problem
from .result import CalibrationError

#: What the paper's noise allows (1 sigma), ../shared/notes/physics-pitfalls.md: (low, high) per group.
NOISE_FLOOR = {
    "accel bias": (0.2, 0.2), "accel scale": (0.25, 0.25), "accel misalignment": (0.12, 0.12),
    "gyro bias": (0.0013, 0.0017), "gyro scale": (0.5, 0.65), "gyro misalignment": (0.12, 0.17),
}
#: The paper's reported accuracy after 3 iterations.
PAPER_ACCURACY = {
    "accel bias": 0.5, "accel scale": 0.5, "accel misalignment": 0.2,
    "gyro bias": 0.0003, "gyro scale": 0.5, "gyro misalignment": 0.2,
}


def group_of(index: int) -> str:
    for label, sl, _ in P.GROUPS:
        if sl.start <= index < sl.stop:
            return label
    raise IndexError(index)


def run_seed(problem: Problem, seed: int, solvers: Sequence[str] = ("ils",)) -> list[dict]:
    """Simulate one seed and calibrate it with each solver; one row per solver and parameter."""
    from .simulate import simulate
    from .solvers import calibrate

    sim = simulate(problem, seed=seed)
    rows = []
    for solver in solvers:
        try:
            res = calibrate(sim.recording, solver=solver)
        except CalibrationError as exc:
            rows.append({"seed": seed, "solver": solver, "failed": str(exc)})
            continue
        err = P.natural_errors(res.parameters.values, sim.truth.values)
        sigma = res.parameters.sigma / P.NATURAL_SCALE
        sigma[P.SCALE_MASK] /= np.abs(res.parameters.values[P.SCALE_MASK])
        first = P.natural_errors(res.history[1], sim.truth.values) if len(res.history) > 1 else err
        for i, name in enumerate(P.NAMES):
            rows.append({"seed": seed, "solver": solver, "parameter": name, "group": group_of(i),
                         "unit": P.NATURAL_UNITS[i], "error": err[i], "sigma": sigma[i],
                         "first_iteration_error": first[i], "iterations": res.iterations,
                         "wall_time": res.wall_time, "failed": ""})
    return rows


def run(problem: Problem, seeds: Sequence[int], solvers: Sequence[str] = ("ils",), workers: int | None = None,
        progress: Callable[[int, int], None] | None = None) -> pd.DataFrame:
    """Run seeds in parallel on local processes; rows of :func:`run_seed`."""
    workers = workers or os.cpu_count() or 1
    rows: list[dict] = []
    if workers == 1:
        for k, seed in enumerate(seeds, 1):
            rows += run_seed(problem, seed, solvers)
            if progress:
                progress(k, len(seeds))
    else:
        with ProcessPoolExecutor(workers) as pool:
            futures = [pool.submit(run_seed, problem, seed, tuple(solvers)) for seed in seeds]
            for k, fut in enumerate(futures, 1):
                rows += fut.result()
                if progress:
                    progress(k, len(seeds))
    return pd.DataFrame(rows)


def summary(frame: pd.DataFrame) -> pd.DataFrame:
    """Per solver and parameter: RMS error, mean sigma, their ratio, and the floor ratio."""
    ok = frame[frame["failed"] == ""]
    out = ok.groupby(["solver", "parameter"], sort=False).agg(
        group=("group", "first"), unit=("unit", "first"),
        rms_error=("error", lambda e: float(np.sqrt(np.mean(np.square(e))))),
        mean_sigma=("sigma", "mean"), max_abs_z=("error", "size"),
        rms_first_iteration=("first_iteration_error", lambda e: float(np.sqrt(np.mean(np.square(e))))),
        runs=("error", "size")).reset_index()
    z = ok.assign(z=np.abs(ok["error"] / ok["sigma"])).groupby(["solver", "parameter"], sort=False)["z"].max()
    out["max_abs_z"] = z.to_numpy()
    out["rms_over_sigma"] = out["rms_error"] / out["mean_sigma"]
    out["floor"] = [NOISE_FLOOR[g][0] for g in out["group"]]
    out["rms_over_floor"] = out["rms_error"] / out["floor"]
    out["paper"] = [PAPER_ACCURACY[g] for g in out["group"]]
    return out
