"""Honest sigma on realistic sensors (issue 9): Monte Carlo of both solvers under five noise worlds.

Run: ``python benchmarks/bench_noise.py [--runs 50] [--workers 2] [--out results]`` (about 40 min on
2 cores for 50 runs).  Writes ``results/noise-montecarlo-runs.csv`` (every run), ``noise-montecarlo.{csv,md}``
(per condition, solver and parameter: RMS error, mean sigma, RMS/sigma, max |z|, runs beyond 4.5
sigma), ``noise-montecarlo-summary.{csv,md}`` (per condition and solver: the range of RMS/sigma over
the 21 parameters), ``noise-montecarlo.png`` and ``noise-raw-estimates.{csv,md}`` (the raw-data noise
estimate against the simulated values).

Conditions (the paper's schedule, 50 seeds each, same seeds in every condition):

* ``paper``: white noise 50 ug and 0.01 deg/h per 100 Hz sample (the paper's world);
* ``realistic``: gyro ARW 0.002 deg/sqrt(h) and accelerometer VRW 15 ug/sqrt(Hz) (120x and 3x the paper);
* ``bias-instability``: the same plus Gauss-Markov bias instability 0.002 deg/h (600 s) and 3 ug (900 s);
  the calibrators are given it as a datasheet would (``--no-datasheet`` adds a run without it);
* ``bias-instability-integer``: the same with integer pulses (the paper's pulse sizes);
* ``sway``: the paper's noise on a base swaying 20-120 arcsec at 2-20 s periods (the ILS refuses).

The accuracy on a swaying base against the still one (``results/noise-sway-ratio*``) is
``benchmarks/bench_moving_base.py``'s.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.data.problem import load_problem
from casadi_sins.noise.raw import estimate_sensor_noise
from casadi_sins.report.plots import save_figure
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate
from casadi_sins.studies import montecarlo as MC


REALISTIC = dict(accel_noise_ug=0.0, gyro_noise_deg_h=0.0, accel_vrw_ug_rthz=15.0, gyro_arw_deg_rth=0.002)
MARKOV = dict(REALISTIC, gyro_bias_instability_deg_h=0.002, gyro_bias_tau_s=600.0, accel_bias_instability_ug=3.0,
              accel_bias_tau_s=900.0)
CONDITIONS = {
    "paper": {},
    "realistic": REALISTIC,
    "bias-instability": MARKOV,
    "bias-instability-integer": dict(MARKOV, quantize=True),
    "sway": dict(sway_amplitude_arcsec=(20.0, 120.0), sway_period_s=(2.0, 20.0)),
}


def raw_estimates(problem, seeds) -> pd.DataFrame:
    """The raw-data noise estimate of every seed against the simulated densities."""
    dev = problem.deviations
    dt = 1.0 / problem.rate_hz
    true_arw = np.hypot(dev.gyro_noise_deg_h * np.sqrt(dt) / 60.0, dev.gyro_arw_deg_rth)
    true_vrw = np.hypot(dev.accel_noise_ug * np.sqrt(dt), dev.accel_vrw_ug_rthz)
    rows = []
    for seed in seeds:
        rec = simulate(problem, seed=seed).recording
        raw = estimate_sensor_noise(rec, rough_parameters(rec).values)
        for sensor, truth, unit in (("gyro", true_arw, "deg/sqrt(h)"), ("accel", true_vrw, "ug/sqrt(Hz)")):
            terms = raw.white[sensor]
            scale = (np.pi / 180 / 60) if sensor == "gyro" else 9.80665e-6
            for axis, term in enumerate(terms):
                rows.append({"seed": seed, "sensor": sensor, "axis": "xyz"[axis], "unit": unit, "simulated": truth,
                             "estimate": term.value / scale, "determined": term.determined,
                             "upper_bound": term.upper_bound / scale})
    return pd.DataFrame(rows)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=50)
    parser.add_argument("--first-seed", type=int, default=20000)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--conditions", nargs="+", default=list(CONDITIONS))
    parser.add_argument("--no-datasheet", action="store_true", help="also run bias-instability without the datasheet")
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    base = load_problem()
    seeds = range(args.first_seed, args.first_seed + args.runs)
    runs = [(name, base.with_changes(**CONDITIONS[name]), True) for name in args.conditions]
    if args.no_datasheet:
        runs.append(("bias-instability-no-datasheet", base.with_changes(**MARKOV), False))
    frames, summaries = [], []
    for name, problem, use_datasheet in runs:
        t0 = time.perf_counter()
        rows = MC.run(problem, seeds, ("nlp", "ils"), args.workers, use_datasheet=use_datasheet)
        rows["condition"] = name
        frames.append(rows)
        summary = MC.summary(rows)
        summary.insert(0, "condition", name)
        summaries.append(summary)
        failed = rows.loc[rows["failed"] != "", ["solver", "seed", "failed"]].drop_duplicates(["solver", "seed"])
        print(f"{name}: {args.runs} runs in {time.perf_counter() - t0:.0f} s; failures: "
              f"{failed.groupby('solver').size().to_dict()}")
        if len(failed):
            print("  e.g.", failed.iloc[0]["solver"], failed.iloc[0]["failed"][:200])
        for solver, part in summary.groupby("solver", sort=False):
            print(f"  {solver}: RMS/sigma {part['rms_over_sigma'].min():.2f}-{part['rms_over_sigma'].max():.2f}, "
                  f"max |z| {part['max_abs_z'].max():.2f}, runs beyond 4.5 sigma {int(part['beyond_4_5_sigma'].sum())}")
    all_rows = pd.concat(frames, ignore_index=True)
    table = pd.concat(summaries, ignore_index=True)
    out = args.out
    all_rows.to_csv(f"{out}/noise-montecarlo-runs.csv", index=False)
    cols = ["condition", "solver", "parameter", "unit", "rms_error", "mean_sigma", "rms_over_sigma", "max_abs_z",
            "beyond_4_5_sigma", "runs"]
    write_frame(table[cols], f"{out}/noise-montecarlo", f"Monte Carlo, {args.runs} seeds per condition: RMS error "
                "against the solver's own sigma (natural units). Regenerate: python benchmarks/bench_noise.py")
    brief = table.groupby(["condition", "solver"], sort=False).agg(
        rms_over_sigma_min=("rms_over_sigma", "min"), rms_over_sigma_max=("rms_over_sigma", "max"),
        max_abs_z=("max_abs_z", "max"), beyond_4_5_sigma=("beyond_4_5_sigma", "sum"), runs=("runs", "min")).reset_index()
    write_frame(brief, f"{out}/noise-montecarlo-summary", "Per condition and solver: RMS/sigma over the 21 parameters "
                "(target 0.8-1.25), largest |z|, runs beyond 4.5 sigma")
    print(brief.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    estimates = pd.concat([raw_estimates(base.with_changes(**CONDITIONS[c]), list(seeds)[:10]).assign(condition=c)
                           for c in ("paper", "realistic", "bias-instability-integer")], ignore_index=True)
    estimates["relative_error"] = estimates["estimate"] / estimates["simulated"] - 1.0
    raw = estimates.groupby(["condition", "sensor"], sort=False).agg(
        simulated=("simulated", "first"), mean_estimate=("estimate", "mean"),
        worst_relative_error=("relative_error", lambda e: float(e.abs().max())),
        determined=("determined", "mean")).reset_index()
    write_frame(raw, f"{out}/noise-raw-estimates", "Raw-data noise estimates (third differences of block sums; a "
                "counter's from block means beneath its pulse) against the simulated white noise, 10 seeds x 3 axes "
                "(determined: share of axes where the raw data fix it; otherwise the fit does)")
    print(raw.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    plot(table, f"{out}/noise-montecarlo.png")


def plot(table: pd.DataFrame, path: str):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    conditions = list(dict.fromkeys(table["condition"]))
    fig, axes = plt.subplots(1, 2, figsize=(14, 4.5), sharey=True)
    for ax, solver in zip(axes, ("nlp", "ils")):
        for k, condition in enumerate(conditions):
            part = table[(table["condition"] == condition) & (table["solver"] == solver)]
            ax.plot(np.arange(len(part)), part["rms_over_sigma"], "o-", ms=3, lw=0.8, label=condition)
        ax.axhspan(0.8, 1.25, color="0.9")
        ax.set_xticks(np.arange(21), [p.replace("_misalign", "_mis").replace("accel_", "a_").replace("gyro_", "g_")
                                      for p in table["parameter"].unique()], rotation=90, fontsize=7)
        ax.set_title(f"{solver}: RMS error / mean sigma (band: 0.8-1.25)")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)


if __name__ == "__main__":
    main()
