"""The reference solver: wall time on the paper's recording (target < 5 s) and a Monte Carlo of accuracy.

Run: ``python benchmarks/bench_ils.py [--seeds 20] [--out results]``.  Prints the solve time and its ratio
to the 5 s target, then the RMS error per parameter against the mean sigma, the noise floor and the paper's
figures; writes ``results/ils-montecarlo.{csv,md}``.
"""

from __future__ import annotations

import argparse
import time

import pandas as pd
from casadi_sins.calibrate import calibrate_ils
from casadi_sins.data.problem import load_problem
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate
from casadi_sins.studies import montecarlo as MC



def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    problem = load_problem()
    rec = simulate(problem, seed=1).recording
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        res = calibrate_ils(rec)
        times.append(time.perf_counter() - t0)
    print(f"ils on {rec.name}: {res.nit} iterations, best {min(times):.2f} s of 3 "
          f"(ratio to the 5 s target {min(times) / 5:.2f})")
    t0 = time.perf_counter()
    rows = MC.run(problem, range(1000, 1000 + args.seeds), ("ils",),
                  progress=lambda k, n: print(f"\r  monte carlo {k}/{n}", end="", flush=True))
    print(f"\n{args.seeds} seeds in {time.perf_counter() - t0:.1f} s")
    summary = MC.summary(rows)
    cols = ["parameter", "unit", "rms_error", "mean_sigma", "rms_over_sigma", "max_abs_z", "floor",
            "rms_over_floor", "paper", "rms_first_iteration"]
    pd.set_option("display.width", 200)
    print(summary[cols].to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    write_frame(summary[cols], f"{args.out}/ils-montecarlo",
                f"ILS Monte Carlo, paper's problem, {args.seeds} seeds: RMS error vs sigma, floor and paper")


if __name__ == "__main__":
    main()
