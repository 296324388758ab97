"""Honest sigma at the edges of real data (issue 16): Monte Carlo of both solvers WITHOUT a datasheet.

Run: ``python benchmarks/bench_edges.py [--runs 50] [--workers 2] [--worlds ...] [--out results]``.

Worlds (the paper's schedule; problem files beside this script):

* ``paper``: ``problems/kang2013.toml`` (white noise 50 ug and 0.01 deg/h per 100 Hz sample);
* ``navbi``: ``edges-navbi.toml``, 200 Hz, navigation-grade noise, Gauss-Markov bias instability, integer
  pulses: the calibration is *not* given the bias instability (no datasheet);
* ``navint``: ``edges-navint.toml``, the same without the bias instability;
* ``coarse``: ``edges-coarse.toml``, a coarse pulse counter (Table 2's pulse sizes at 200 Hz) with 30 ug and
  0.02 deg/h white noise per sample.

Per world and solver: RMS error / mean sigma for every parameter (the bar: 0.8-1.25), the runs with some
``|z| > 4.5`` (chance: 0.007 runs in 50 with 21 honest parameters), the runs whose joint chi-square of the 21
against the truth lies outside its 0.1 % and 99.9 % points (6.4-46.8; chance: 0.1 run in 50), its median
(21 when honest), and the runs with a warning.  Writes ``edges-montecarlo-runs.csv`` (every run and
parameter), ``edges-montecarlo.{csv,md}`` (per world, solver and parameter) and
``edges-montecarlo-summary.{csv,md}``.  Same seeds in every world.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd
from casadi_sins.data.problem import load_problem
from casadi_sins.report.tables import write_frame
from casadi_sins.studies import montecarlo as MC

HERE = Path(__file__).resolve().parent
WORLDS = {"paper": HERE.parent / "problems" / "kang2013.toml", "navbi": HERE / "edges-navbi.toml",
          "navint": HERE / "edges-navint.toml", "coarse": HERE / "edges-coarse.toml"}
#: The joint chi-square of 21 honest parameters lies between these in 99.8 % of recordings.
CHI_SQUARE_BAND = (6.4, 46.8)
Z_LIMIT = 4.5


def world_summary(rows: pd.DataFrame) -> pd.DataFrame:
    """Per solver: the range of RMS/sigma over the parameters, the worst, and the run counts of the bar."""
    out = []
    ok = rows[rows["failed"] == ""]
    for solver, part in ok.groupby("solver", sort=False):
        per = MC.summary(part)
        runs = part.groupby("seed")
        max_z = runs.apply(lambda r: float(np.max(np.abs(r["error"] / r["sigma"]))), include_groups=False)
        chi = runs["chi_square"].first()
        worst = per.iloc[int(np.argmax(np.abs(np.log(per["rms_over_sigma"]))))]
        out.append({"solver": solver, "runs": len(chi),
                    "failed": int(rows[(rows["solver"] == solver) & (rows["failed"] != "")]["seed"].nunique()),
                    "rms_over_sigma_min": per["rms_over_sigma"].min(), "rms_over_sigma_max": per["rms_over_sigma"].max(),
                    "worst_parameter": worst["parameter"], "worst_rms_over_sigma": worst["rms_over_sigma"],
                    "outside_0.8_1.25": int(((per["rms_over_sigma"] < 0.8) | (per["rms_over_sigma"] > 1.25)).sum()),
                    "runs_beyond_4.5": int((max_z > Z_LIMIT).sum()),
                    "chi_square_median": float(chi.median()),
                    "runs_chi_square_outside": int(((chi < CHI_SQUARE_BAND[0]) | (chi > CHI_SQUARE_BAND[1])).sum()),
                    "runs_with_warning": int((runs["warnings"].first() > 0).sum())})
    return pd.DataFrame(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--first-seed", type=int, default=20000)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--worlds", nargs="+", choices=list(WORLDS), default=list(WORLDS))
    ap.add_argument("--out", default="results")
    args = ap.parse_args()
    seeds = range(args.first_seed, args.first_seed + args.runs)
    runs, tables, summaries = [], [], []
    for world in args.worlds:
        problem = load_problem(WORLDS[world])
        t0 = time.perf_counter()
        rows = MC.run(problem, seeds, solvers=("nlp", "ils"), workers=args.workers, use_datasheet=False,
                      progress=lambda done, total: print(f"\r{world}: {done}/{total}", end="", flush=True))
        print(f"\r{world}: {args.runs} runs in {time.perf_counter() - t0:.0f} s")
        rows.insert(0, "world", world)
        runs.append(rows)
        ok = rows[rows["failed"] == ""]
        for solver, part in ok.groupby("solver", sort=False):
            tables.append(MC.summary(part).assign(world=world, solver=solver))
        summary = world_summary(rows).assign(world=world)
        summaries.append(summary)
        print(summary.drop(columns="world").to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    pd.concat(runs).to_csv(out / "edges-montecarlo-runs.csv", index=False)
    table = pd.concat(tables)
    table = table[["world", "solver"] + [c for c in table.columns if c not in ("world", "solver")]]
    write_frame(table, out / "edges-montecarlo", title="Issue 16: RMS error / mean sigma per parameter, "
                f"no datasheet, {args.runs} seeds from {args.first_seed}")
    summary = pd.concat(summaries)
    summary = summary[["world"] + [c for c in summary.columns if c != "world"]]
    write_frame(summary, out / "edges-montecarlo-summary", title="Issue 16 bar: per world and solver "
                f"(no datasheet, {args.runs} seeds; RMS/sigma bar 0.8-1.25, chi-square band 6.4-46.8)")


if __name__ == "__main__":
    main()
