"""Monte Carlo throughput: N runs (simulate + both solvers) on the local cores against sequential runs.

Run: ``python benchmarks/bench_montecarlo.py [--runs 100]``.  Target: the parallel time within the
sequential time divided by ~1.8 on this 2-core machine.  The sequential time is measured on the same
number of runs.
"""

from __future__ import annotations

import argparse
import os
import time
from casadi_sins.data.problem import load_problem
from casadi_sins.studies import montecarlo as MC



def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=100)
    args = parser.parse_args()
    problem = load_problem()
    seeds = range(20000, 20000 + args.runs)
    t0 = time.perf_counter()
    MC.run(problem, seeds, ("nlp", "ils"), workers=1)
    sequential = time.perf_counter() - t0
    t0 = time.perf_counter()
    MC.run(problem, seeds, ("nlp", "ils"), workers=os.cpu_count())
    parallel = time.perf_counter() - t0
    print(f"{args.runs} runs: sequential {sequential:.1f} s, {os.cpu_count()} workers {parallel:.1f} s, "
          f"speed-up {sequential / parallel:.2f} (target >= 1.8)")


if __name__ == "__main__":
    main()
