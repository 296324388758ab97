"""A coarse pulse counter's quantization told apart from its white noise (issue 16): Monte Carlo of both solvers.

Run: ``python benchmarks/bench_quantization.py [--runs 20] [--workers 2] [--out results]`` (about 2 min per 20
runs on one core).  Writes ``results/quantization-montecarlo-runs.csv`` (every run and parameter) and
``quantization-montecarlo.{csv,md}``: per solver the range of RMS error / mean sigma over the 21 parameters, the
joint chi-square of the 21 against the truth (``e^T C^-1 e``, 21 degrees of freedom: median, runs outside its
0.1 % and 99.9 % points 6.4-46.8), runs with warnings, and the raw-data estimate of the white noise against the simulated one.

The world: the paper's schedule at 200 Hz with integer pulses of 144 per sample over white noise of 30 ug and
0.02 deg/h per sample (0.004 pulse): the remainder is a thousand times the white noise in every sample.  No
datasheet: every noise term comes from the recording.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import os
import time

import numpy as np
import pandas as pd

from casadi_sins.calibrate import CalibrationError, calibrate
from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.data.problem import load_problem
from casadi_sins.model.noise import SensorNoise
from casadi_sins.model.parameters import joint_chi_square, natural_errors
from casadi_sins.model.registry import ACCEL_SCALE, GYRO_SCALE
from casadi_sins.noise.raw import estimate_sensor_noise
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate
from casadi_sins.studies.parallel import run_all

COARSE = dict(accel_noise_ug=30.0, gyro_noise_deg_h=0.02, quantize=True)
#: The 0.1 % and 99.9 % points of a chi-square with 21 degrees of freedom.
CHI2_BAND = (6.4, 46.8)


def coarse_problem():
    """The paper's problem at 200 Hz with a coarse pulse counter."""
    return dataclasses.replace(load_problem().with_changes(**COARSE), rate_hz=200.0, name="coarse-counter")


def run_seed(problem, seed: int) -> tuple[list[dict], list[dict]]:
    """One seed: the raw estimate against the truth, and both solvers without a datasheet."""
    sim = simulate(problem, seed=seed)
    rec, truth = sim.recording, sim.truth
    raw = estimate_sensor_noise(rec, rough_parameters(rec).values)
    true = SensorNoise.from_deviations(problem.deviations, rec.dt, np.abs(truth.values[GYRO_SCALE]),
                                       np.abs(truth.values[ACCEL_SCALE]))
    raws = [{"seed": seed, "term": term, "axis": "xyz"[a], "ratio": est.value / simulated[a],
             "z": (est.value - simulated[a]) / est.standard_error, "determined": est.determined}
            for term, estimates, simulated in (("ARW", raw.white["gyro"], true.gyro_arw),
                                               ("VRW", raw.white["accel"], true.accel_vrw))
            for a, est in enumerate(estimates)]
    rows = []
    for solver in ("nlp", "ils"):
        try:
            res = calibrate(rec, solver=solver)
        except CalibrationError as exc:
            rows.append({"seed": seed, "solver": solver, "failed": str(exc)})
            continue
        err, sigma, chi2 = natural_errors(res.parameters, truth), res.parameters.natural_sigma(), \
            joint_chi_square(res.parameters, truth)
        rows += [{"seed": seed, "solver": solver, "parameter": name, "error": err[i], "sigma": sigma[i],
                  "chi2": chi2, "warnings": " | ".join(res.warnings), "failed": ""}
                 for i, name in enumerate(res.parameters.names)]
    return rows, raws


def summarize(runs: pd.DataFrame, raws: pd.DataFrame) -> pd.DataFrame:
    """Per solver: RMS/sigma range, joint chi-square, warnings; per raw term: ratio to the truth."""
    out = []
    ok = runs[runs["failed"] == ""]
    for solver, part in ok.groupby("solver", sort=False):
        ratio = part.groupby("parameter", sort=False).apply(
            lambda x: np.sqrt(np.mean(x["error"] ** 2)) / np.mean(x["sigma"]))
        per_run = part.groupby("seed").agg(chi2=("chi2", "first"), warnings=("warnings", "first"))
        outside = (per_run["chi2"] < CHI2_BAND[0]) | (per_run["chi2"] > CHI2_BAND[1])
        out.append({"what": solver, "runs": len(per_run),
                    "range": f"RMS/sigma {ratio.min():.2f} ({ratio.idxmin()}) - {ratio.max():.2f} ({ratio.idxmax()})",
                    "chi2_median": round(float(per_run["chi2"].median()), 1), "chi2_outside_band": int(outside.sum()),
                    "runs_with_warnings": int((per_run["warnings"] != "").sum()),
                    "failed": int(runs.loc[runs["solver"] == solver, "failed"].ne("").sum())})
    for term, part in raws.groupby("term", sort=False):
        out.append({"what": f"raw {term}", "runs": part["seed"].nunique(),
                    "range": f"raw/true {part['ratio'].min():.2f} - {part['ratio'].max():.2f}, (raw - true)/SE rms "
                             f"{np.sqrt(np.mean(part['z'] ** 2)):.2f}, determined {int(part['determined'].sum())}/"
                             f"{len(part)} axes"})
    return pd.DataFrame(out)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=20000)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    problem = coarse_problem()
    t0 = time.perf_counter()
    rows, raws = [], []
    for seed_rows, seed_raws in run_all(functools.partial(run_seed, problem),
                                        range(args.first_seed, args.first_seed + args.runs), args.workers):
        rows += seed_rows
        raws += seed_raws
    runs, raws = pd.DataFrame(rows).sort_values("seed", kind="stable"), pd.DataFrame(raws)
    table = summarize(runs, raws)
    print(f"{args.runs} runs in {time.perf_counter() - t0:.0f} s")
    print(table.to_string(index=False))
    os.makedirs(args.out, exist_ok=True)
    runs.to_csv(f"{args.out}/quantization-montecarlo-runs.csv", index=False)
    write_frame(table, f"{args.out}/quantization-montecarlo",
                f"Coarse pulse counter (issue 16), {args.runs} seeds from {args.first_seed}, no datasheet: "
                "RMS error over mean sigma per parameter (range over the 21), joint chi-square of the 21 (band "
                "6.4-46.8), and the raw-data white noise against the simulated.  Regenerate: python "
                "benchmarks/bench_quantization.py")


if __name__ == "__main__":
    main()
