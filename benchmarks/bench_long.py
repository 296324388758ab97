"""A long file: 10 h at 400 Hz (14.2 million samples) from recording to table (issue 11: < 2 min, < 4 GB).

Run: ``python benchmarks/bench_long.py [--out results]``.  Simulates ``problems/long-10h-400hz.toml`` into
``runs/long/`` once (about 2 min, 1.8 GB of CSV), then runs ``casadi-sins calibrate`` on it in a child
process and reports the wall time, the peak memory and the errors against the truth in units of sigma;
writes ``results/long-file.{csv,md}``.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from casadi_sins.data.problem import load_problem
from casadi_sins.data.tables import read_table
from casadi_sins.model.parameters import natural_errors
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate, write_simulation

ROOT = Path(__file__).resolve().parents[1]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default=str(ROOT / "results"))
    parser.add_argument("--runs", default=str(ROOT / "runs" / "long"))
    args = parser.parse_args()

    problem = load_problem(ROOT / "problems" / "long-10h-400hz.toml")
    runs = Path(args.runs)
    toml = runs / f"{problem.name}-seed1.toml"
    if not toml.exists():
        t0 = time.perf_counter()
        write_simulation(simulate(problem, seed=1), runs)
        print(f"simulated and wrote {toml} in {time.perf_counter() - t0:.0f} s")
    table = runs / "long-params.csv"
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "casadi_sins", "calibrate", str(toml), "--out", str(table)],
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    peak_gb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1e6
    if done.returncode:
        raise SystemExit(done.stderr)
    result = read_table(table)
    truth = read_table(runs / f"{problem.name}-seed1.truth.csv")
    z = natural_errors(result, truth) / result.natural_sigma()
    samples = int(round(problem.duration * problem.rate_hz))
    frame = pd.DataFrame([{"samples": samples, "hours": problem.duration / 3600, "rate (Hz)": problem.rate_hz,
                           "wall time (s)": wall, "peak memory (GB)": peak_gb, "target time (s)": 120,
                           "target memory (GB)": 4, "max |error| / sigma": float(np.abs(z).max()),
                           "rms error / sigma": float(np.sqrt(np.mean(z**2)))}])
    print(frame.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    write_frame(frame, f"{args.out}/long-file", "10 h at 400 Hz: casadi-sins calibrate, whole process (read, noise, "
                "graph, solve, checks, report)")


if __name__ == "__main__":
    main()
