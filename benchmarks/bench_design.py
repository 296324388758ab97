"""Speed and quality of the schedule design against its search budget.

Run: ``python benchmarks/bench_design.py [--budgets 30 100 300] [--total-s 1290] [--out results]``.
For the paper's unit and schedule length, designs the schedule with each number of scored
orientation sequences (``--evaluations``) and records the CPU and wall time, the predictions made,
and the quality of the design against the paper's schedule: the criterion, the geometric-mean
sigma ratio over the 21 parameters and the worst ratio.  The CPU time is the process's own (the
machine may be shared); the wall time is what a user waits.
"""

from __future__ import annotations

import argparse
import time

import pandas as pd
from casadi_sins.data.problem import load_problem
from casadi_sins.report.tables import write_frame
from casadi_sins.studies.design.criteria import Criterion
from casadi_sins.studies.design.run import default_rate
from casadi_sins.studies.design.search import design
from casadi_sins.studies.design.space import Limits


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--budgets", type=int, nargs="+", default=[30, 100, 300])
    parser.add_argument("--total-s", type=float, default=1290.0)
    parser.add_argument("--angles", default="90,180")
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    base = load_problem()
    limits = Limits(total_s=args.total_s, max_rate_deg_s=default_rate(base),
                    angles=tuple(int(a) for a in args.angles.split(",")))
    rows = []
    for budget in args.budgets:
        crit = Criterion("d", base)
        wall, cpu = time.perf_counter(), time.process_time()
        best = design(base, limits, crit, evaluations=budget)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        rows.append({"evaluations": budget, "predictions": crit.evaluations, "cpu_s": round(cpu, 1),
                     "wall_s": round(wall, 1), "cpu_per_prediction_s": round(cpu / crit.evaluations, 3),
                     "criterion_d": round(best.score.value, 4), "geometric_mean_ratio": round(best.score.geometric_mean, 4),
                     "worst_ratio": round(float(best.score.ratios.max()), 4),
                     "turns": sum(len(g.turns) for g in best.groups), "groups": len(best.groups)})
        print(rows[-1], flush=True)
    write_frame(pd.DataFrame(rows), f"{args.out}/design-benchmark",
                f"design of the paper's unit in {args.total_s:g} s against the search budget (criterion d, seed 0)")


if __name__ == "__main__":
    main()
