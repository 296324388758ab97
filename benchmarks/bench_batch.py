"""Batch throughput on a local Dask cluster: one worker against two.

Run: ``python benchmarks/bench_batch.py [--units 12] [--static-s 100] [--repeats 5] [--out results]``.  Simulated units of the paper's
schedule are written to a temporary folder and calibrated by :func:`studies.batch.run_batch` through
a Dask cluster started beforehand (its scheduler address is passed, as for a remote cluster), so the
timing is the batch itself, not the cluster's start.  Target: two workers at least 1.6x faster than
one on this 2-core machine.  The load of the machine before each run and the cores the workers got
(their CPU seconds over the wall time) are printed: other work on the cores lowers the ratio.  The two runs alternate ``--repeats`` times; the medians and their
ratio are written to ``results/batch-dask.{csv,md}``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import tempfile
import time
from pathlib import Path

import pandas as pd
from casadi_sins.data.problem import load_problem
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate, write_simulation
from casadi_sins.studies.batch import run_batch


def _cpu_seconds() -> float:
    import resource

    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def timed_batch(paths, out: Path, workers: int) -> tuple[float, float]:
    """Wall seconds for one batch of ``paths`` on a fresh local Dask cluster of ``workers`` processes, and
    the CPU seconds its workers used (their ratio shows how much of the cores the batch got)."""
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        before = client.run(_cpu_seconds)
        print(f"load average before {workers} worker(s): {os.getloadavg()[0]:.2f}")
        t0 = time.perf_counter()
        fleet = run_batch(paths, out, scheduler=cluster.scheduler_address, resume=False)
        elapsed = time.perf_counter() - t0
        per_worker = [after - before[w] for w, after in client.run(_cpu_seconds).items()]
    cpu = sum(per_worker)
    assert (fleet["status"] != "failed").all(), fleet[["unit_id", "message"]]
    print(f"{workers} worker(s): {elapsed:.1f} s wall, {cpu:.1f} s CPU in the workers ({cpu / elapsed:.2f} cores used; "
          f"per worker {', '.join(f'{c:.1f}' for c in per_worker)} s)")
    return elapsed, cpu


def main():
    """Simulate the units, time the batch on one and on two Dask workers, print the ratio."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--units", type=int, default=12, help="number of simulated units (default 12)")
    parser.add_argument("--static-s", type=float, default=100.0, help="static segment length, s (default 100: "
                        "the paper's)")
    parser.add_argument("--repeats", type=int, default=5, help="alternating runs of each (default 5)")
    parser.add_argument("--out", default="results", help="folder of batch-dask.{csv,md} (default results)")
    args = parser.parse_args()
    os.environ["OMP_NUM_THREADS"] = "1"
    problem = load_problem()
    problem = dataclasses.replace(problem, timing=dataclasses.replace(problem.timing, static_s=args.static_s))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        paths = [write_simulation(simulate(problem, seed=k, name=f"U{k:03d}"), root / "rec") for k in range(args.units)]
        for repeat in range(args.repeats):
            for workers in (1, 2):
                load = os.getloadavg()[0]  # before the run
                wall, cpu = timed_batch(paths, root / f"{workers}-{repeat}", workers)
                rows.append({"repeat": repeat, "workers": workers, "wall_s": wall, "cpu_s": cpu, "load_average": load})
    frame = pd.DataFrame(rows)
    one = statistics.median(frame[frame["workers"] == 1]["wall_s"])
    two = statistics.median(frame[frame["workers"] == 2]["wall_s"])
    ratios = (frame[frame["workers"] == 1]["wall_s"].to_numpy() / frame[frame["workers"] == 2]["wall_s"].to_numpy())
    print(f"{args.units} units ({args.static_s:g} s statics), median of {args.repeats}: 1 Dask worker {one:.1f} s, "
          f"2 workers {two:.1f} s, speed-up {one / two:.2f} (paired ratios {', '.join(f'{r:.2f}' for r in ratios)}; "
          "target >= 1.6)")
    write_frame(frame, Path(args.out) / "batch-dask", title=f"Batch of {args.units} simulated units on a local Dask "
                f"cluster: 1 worker against 2, alternating; median wall {one:.2f} s against {two:.2f} s, speed-up "
                f"{one / two:.2f} (target 1.6)")

if __name__ == "__main__":
    main()
