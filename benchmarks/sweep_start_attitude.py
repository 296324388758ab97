"""The paper's claim measured: sweep the start attitude error (0.4, 1, 2, 5, 10 deg), several seeds each.

Run: ``python benchmarks/sweep_start_attitude.py [--seeds 6] [--solvers ils] [--out results]``.
Writes ``results/start-attitude-sweep.{csv,md,png}`` and the per-run rows.
"""

from __future__ import annotations

import argparse
import time
from casadi_sins.data.problem import load_problem
from casadi_sins.studies.sweep import start_attitude_sweep, write_sweep



def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--angles", type=float, nargs="*", default=[0.4, 1, 2, 5, 10])
    parser.add_argument("--solvers", nargs="*", default=["ils"])
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    t0 = time.perf_counter()
    rows = start_attitude_sweep(load_problem(), args.angles, range(2000, 2000 + args.seeds), args.solvers,
                                progress=print)
    table = write_sweep(rows, args.out)
    print(table.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(f"{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
