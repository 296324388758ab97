"""Timing of one navigation pass over the paper's recording (issue target: under 1 s).

Run: ``python benchmarks/bench_navigation.py``.  Prints the time of each stage
(best of several repeats) and the ratio to the 1 s target.
"""

from __future__ import annotations

import time

import numpy as np
from casadi_sins.data.problem import load_problem
from casadi_sins.model.output import compensate
from casadi_sins.nav.navigation import navigate, navigation_chain
from casadi_sins.sim import simulate



def best_of(fn, repeats=5):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main():
    problem = load_problem()
    t0 = time.perf_counter()
    sim = simulate(problem, seed=1)
    t_sim = time.perf_counter() - t0
    rec = sim.recording
    params = sim.truth.values
    t0 = time.perf_counter()
    navigate(rec, params)  # first pass includes loading (or compiling) the step
    t_first = time.perf_counter() - t0
    t_nav = best_of(lambda: navigate(rec, params))
    t_comp = best_of(lambda: compensate(rec.gyro, rec.accel, params, rec.dt))
    n = rec.group_samples(1).stop - rec.group_samples(1).start
    x0 = np.zeros(13)
    x0[0] = 1.0
    increments = np.zeros((n, 6))
    t_chain = best_of(lambda: navigation_chain()(x0, np.zeros(6), increments))
    print(f"recording: {len(rec.time)} samples at {rec.rate_hz:g} Hz ({rec.time[-1]:g} s)")
    print(f"simulate                      {t_sim:7.3f} s")
    print(f"navigate, first call          {t_first:7.3f} s (loads the compiled step)")
    print(f"navigate, one pass            {t_nav:7.3f} s   ratio to 1 s target: {t_nav / 1.0:.2f}")
    print(f"  compensation of all samples {t_comp:7.3f} s")
    print(f"  one group's chain ({n} steps) {t_chain:7.3f} s")


if __name__ == "__main__":
    main()
