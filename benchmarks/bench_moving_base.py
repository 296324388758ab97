"""Calibration on a moving base (issue 38): the swaying base and a ship's deck against the still base.

Run: ``python benchmarks/bench_moving_base.py [--runs 20] [--workers 2] [--out results]`` (about 20 min on
2 cores for 20 runs).  The same seeds on three problems that differ only in the base's motion (the
simulator draws the motion after everything else, so the sensor noise of a seed is nearly the same):

* ``still``: the paper's experiment (``problems/kang2013.toml``);
* ``sway``: the base turns about the unit's centre by 20-63 arcsec at 3-17 s (``problems/kang2013-sway.toml``);
* ``deck``: the sway and a deck's heave and surge of 2-18 cm at 3-13 s, 15 mg peak (``problems/kang2013-deck.toml``).

Writes ``results/noise-sway-ratio.{csv,md}`` (the NLP's RMS error on the swaying base and on the deck over the
still base's, per parameter), ``results/moving-base.{csv,md}`` (per condition and parameter: RMS error, mean
sigma, RMS/sigma, max |z|, runs beyond 4.5 sigma) and ``results/moving-base-summary.md`` (per condition: the
worst parameter of each group, RMS/sigma range, max |z|, runs whose table the checks distrust, failed runs),
and prints what the ILS says on the swaying base.  Whole-process speed against the still base is
``benchmarks/bench_speed.py``'s (swaying base and deck).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
from casadi_sins.calibrate import CalibrationError, calibrate
from casadi_sins.data.problem import load_problem
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate
from casadi_sins.studies import montecarlo as MC

CONDITIONS = {"still": "problems/kang2013.toml", "sway": "problems/kang2013-sway.toml",
              "deck": "problems/kang2013-deck.toml"}
GROUPS = {"gyro bias": "gyro_bias", "accel bias": "accel_bias", "gyro scale": "gyro_scale",
          "accel scale": "accel_scale", "misalignment": "misalign"}


def condition_summary(rows: pd.DataFrame, summary: pd.DataFrame) -> dict:
    """One line per condition: the worst RMS error of each group, the sigma's honesty, what the checks said."""
    ok = rows[rows["failed"] == ""]
    out = {}
    for label, key in GROUPS.items():
        part = summary[summary["parameter"].str.contains(key)]
        out[f"worst RMS {label}"] = float(part["rms_error"].max())
        out[f"worst error {label}"] = float(ok[ok["parameter"].str.contains(key)]["error"].abs().max())
    out["RMS/sigma"] = f"{summary['rms_over_sigma'].min():.2f}-{summary['rms_over_sigma'].max():.2f}"
    out["max |z|"] = float(summary["max_abs_z"].max())
    runs = ok.drop_duplicates("seed")
    beyond = ok.assign(b=np.abs(ok["error"] / ok["sigma"]) > 4.5).groupby("seed")["b"].any()
    trusted = ~runs.set_index("seed")["distrusted"]
    out["runs"] = int(rows["seed"].nunique())
    out["failed (exit 2)"] = int(rows[rows["failed"] != ""]["seed"].nunique())
    out["distrusted (exit 2)"] = int(runs["distrusted"].sum())
    out["exit 0 beyond 4.5 sigma"] = int((beyond & trusted.reindex(beyond.index)).sum())
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=38000)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.runs))
    frames, summaries = {}, {}
    for name, path in CONDITIONS.items():
        t0 = time.perf_counter()
        rows = MC.run(load_problem(path), seeds, ("nlp",), args.workers)
        frames[name] = rows
        summaries[name] = MC.summary(rows).assign(condition=name)
        print(f"{name}: {args.runs} runs in {time.perf_counter() - t0:.0f} s")
    still = summaries["still"].set_index("parameter")["rms_error"]
    ratio = pd.DataFrame({"parameter": still.index,
                          "sway_over_still": (summaries["sway"].set_index("parameter")["rms_error"] / still).values,
                          "deck_over_still": (summaries["deck"].set_index("parameter")["rms_error"] / still).values})
    write_frame(ratio, f"{args.out}/noise-sway-ratio", f"NLP RMS error on the swaying base and on the deck over the "
                f"still base ({args.runs} seeds, paper noise; regenerate: python benchmarks/bench_moving_base.py)")
    cols = ["condition", "parameter", "unit", "rms_error", "mean_sigma", "rms_over_sigma", "max_abs_z",
            "beyond_4_5_sigma", "runs"]
    write_frame(pd.concat(summaries.values(), ignore_index=True)[cols], f"{args.out}/moving-base",
                f"NLP on the still base, the swaying base and the deck, {args.runs} seeds each (natural units)")
    brief = pd.DataFrame([{"condition": name, **condition_summary(frames[name], summaries[name])}
                          for name in CONDITIONS])
    write_frame(brief, f"{args.out}/moving-base-summary", "Per condition: the worst parameter of each group (RMS and "
                "largest error over the runs; deg/h, ug, ppm, arcsec), the sigma's honesty, runs the checks refuse")
    print(ratio.round(2).to_string(index=False))
    print(brief.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    sim = simulate(load_problem(CONDITIONS["sway"]), seed=seeds[0])
    try:
        calibrate(sim.recording, solver="ils")
        print("ils on the swaying base: calibrated")
    except CalibrationError as exc:
        print(f"ils on the swaying base: refused: {exc}")


if __name__ == "__main__":
    main()
