"""Uncertainty a production line can trust (issue 40): Monte Carlo of both solvers WITHOUT a datasheet.

Run: ``python benchmarks/bench_uncertainty.py [--runs 40] [--first-seed 70000] [--recipes ...] [--designs 10]
[--out results]`` (one process; about 40 minutes on a loaded two-core machine for the defaults).

Recipes (problem files; the calibration is never given a datasheet):

* ``paper``: ``problems/kang2013.toml``, white noise only: how often a bias instability is modelled (the bar:
  at most 1 in 40) and how often a warning (``--model auto``) is raised (none);
* ``navbi``: ``edges-navbi.toml``, navigation-grade noise with a Gauss-Markov bias instability and integer pulses:
  the runs with some ``|error/sigma| > 4.5``;
* ``coarse``: ``edges-coarse.toml``, issue 16's coarse counter (the raw data determine the white noise), and
  ``coarse-fine``: the same counter over 8 ug and 0.005 deg/h of white noise, which the pulses hide (the fit sets
  it): the RMS of error/sigma per parameter (the bar: 0.5-1.5 for the ILS);
* ``extended`` and ``gsens``: ``problems/extended-kang2013.toml`` and ``problems/extended-gsens.toml`` with the
  default 21-parameter model: the warning that names the extra terms (``--model auto``);
* ``design``: ``--designs`` schedules of 300 s designed by ``casadi-sins design problems/kang2013.toml --total-s
  300 --seed K``, one recording each: the summed joint chi-square of each solver against its 95 % band.

Writes ``uncertainty-runs.csv`` (every run and parameter), ``uncertainty-summary.{csv,md}`` (per recipe and
solver) and ``uncertainty-montecarlo.{csv,md}`` (RMS of error/sigma per recipe, solver and parameter).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
import pandas as pd
from casadi_sins.calibrate import CalibrationError, calibrate
from casadi_sins.data.problem import load_problem
from casadi_sins.model.parameters import joint_chi_square, natural_errors
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate
from casadi_sins.studies.consistency import chi_square_band, rms_ratio_band

HERE = Path(__file__).resolve().parent
PROBLEMS = HERE.parent / "problems"
RECIPES = {"paper": PROBLEMS / "kang2013.toml", "navbi": HERE / "edges-navbi.toml",
           "coarse": HERE / "edges-coarse.toml", "coarse-fine": HERE / "edges-coarse.toml",
           "extended": PROBLEMS / "extended-kang2013.toml", "gsens": PROBLEMS / "extended-gsens.toml"}
#: Runs of the recipes whose calibration is slow (the extra groups' evidence), when ``--runs`` is larger.
FEW_RUNS = {"extended": 3, "gsens": 2}
Z_LIMIT = 4.5
#: Orientation sequences each design's search scores (the command's default is 300; the bar is on the recordings).
DESIGN_EVALUATIONS = 60


def recipe_problem(name: str):
    """The problem of a recipe (``coarse-fine``: the coarse counter over white noise its pulses hide)."""
    problem = load_problem(RECIPES[name])
    if name == "coarse-fine":
        problem = dataclasses.replace(problem.with_changes(accel_noise_ug=8.0, gyro_noise_deg_h=0.005),
                                      name="coarse-fine")
    return problem


def run_rows(recipe: str, problem, seed: int, solvers) -> list[dict]:
    """Simulate one seed and calibrate it with each solver, no datasheet: one row per solver and parameter."""
    sim = simulate(problem, seed=seed)
    rows = []
    for solver in solvers:
        t0 = time.perf_counter()
        try:
            res = calibrate(sim.recording, solver=solver)
        except CalibrationError as exc:
            rows.append({"recipe": recipe, "seed": seed, "solver": solver, "failed": str(exc)})
            continue
        params = res.parameters
        z = natural_errors(params, sim.truth) / params.natural_sigma()
        wander = res.noise.bias_wander or {}
        common = {"recipe": recipe, "seed": seed, "solver": solver, "failed": "",
                  "joint_chi_square": joint_chi_square(params, sim.truth), "max_abs_z": float(np.max(np.abs(z))),
                  "wander_accel": bool(wander.get("accel") and wander["accel"].included),
                  "wander_gyro": bool(wander.get("gyro") and wander["gyro"].included),
                  "lr_accel": wander["accel"].lr if "accel" in wander else np.nan,
                  "lr_gyro": wander["gyro"].lr if "gyro" in wander else np.nan,
                  "warnings": len(res.warnings), "model_auto_warning": any("--model auto" in w for w in res.warnings),
                  "notes": len(res.notes), "wall_time": time.perf_counter() - t0}
        rows += [common | {"parameter": n, "error_over_sigma": float(v)} for n, v in zip(params.names, z)]
    return rows


def designed_problems(count: int) -> list:
    """``count`` schedules of 300 s designed for the paper's unit (search seeds 1..count)."""
    from casadi_sins.studies.design.run import default_rate, run_design
    from casadi_sins.studies.design.space import Limits

    base = load_problem(PROBLEMS / "kang2013.toml")
    limits = Limits(total_s=300.0, max_rate_deg_s=default_rate(base), min_rest_s=30.0, first_rest_s=60.0,
                    handling_s=60.0, angles=(90, 180), table_axes=3, profile=base.timing.rate_profile)
    out_problems = []
    for k in range(1, count + 1):
        run = run_design(base, limits, evaluations=DESIGN_EVALUATIONS, seed=k)
        out_problems.append(dataclasses.replace(run.problem, name=f"design-300s-{k}"))
    return out_problems


def summary(rows: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per recipe and solver (the bar's counts), and per parameter (RMS of error/sigma)."""
    ok = rows[rows["failed"] == ""]
    per_parameter = (ok.groupby(["recipe", "solver", "parameter"], sort=False)["error_over_sigma"]
                     .apply(lambda z: float(np.sqrt(np.mean(z**2)))).rename("rms_error_over_sigma").reset_index())
    out = []
    for (recipe, solver), part in ok.groupby(["recipe", "solver"], sort=False):
        runs = part.groupby("seed").first()
        n = len(runs)
        rms = per_parameter[(per_parameter["recipe"] == recipe) & (per_parameter["solver"] == solver)]
        joint = float(runs["joint_chi_square"].sum())
        band = chi_square_band(21 * n)
        low, high = rms_ratio_band(n)
        out.append({"recipe": recipe, "solver": solver, "runs": n,
                    "failed": int(rows[(rows["recipe"] == recipe) & (rows["solver"] == solver)
                                       & (rows["failed"] != "")]["seed"].nunique()),
                    "rms_z_min": rms["rms_error_over_sigma"].min(), "rms_z_max": rms["rms_error_over_sigma"].max(),
                    "rms_z_band": f"{low:.2f}-{high:.2f}",
                    "runs_beyond_4.5": int((runs["max_abs_z"] > Z_LIMIT).sum()),
                    "joint_chi_square": joint, "joint_band": f"{band[0]:.0f}-{band[1]:.0f}",
                    "joint_in_band": band[0] <= joint <= band[1],
                    "runs_wander_modelled": int((runs["wander_accel"] | runs["wander_gyro"]).sum()),
                    "runs_with_warning": int((runs["warnings"] > 0).sum()),
                    "runs_model_auto_warning": int(runs["model_auto_warning"].sum()),
                    "runs_with_note": int((runs["notes"] > 0).sum()),
                    "median_wall_time_s": float(runs["wall_time"].median())})
    return pd.DataFrame(out), per_parameter


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40)
    parser.add_argument("--runs-of", nargs="*", default=[], metavar="RECIPE=N", help="runs of single recipes")
    parser.add_argument("--first-seed", type=int, default=70000)
    parser.add_argument("--recipes", nargs="+", default=list(RECIPES), choices=list(RECIPES))
    parser.add_argument("--designs", type=int, default=10)
    parser.add_argument("--solvers", nargs="+", default=["nlp", "ils"])
    parser.add_argument("--out", default="results")
    parser.add_argument("--merge", metavar="RUNS_CSV",
                        help="an earlier uncertainty-runs.csv: its recipes not run now are kept in the files")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    t0 = time.perf_counter()
    for recipe in args.recipes:
        problem = recipe_problem(recipe)
        runs = dict(item.split("=") for item in args.runs_of).get(recipe)
        runs = int(runs) if runs else min(args.runs, FEW_RUNS.get(recipe, args.runs))
        for seed in range(args.first_seed, args.first_seed + runs):
            rows += run_rows(recipe, problem, seed, args.solvers)
            print(f"{recipe} seed {seed} done ({time.perf_counter() - t0:.0f} s)", flush=True)
    if args.designs:
        print("designing", flush=True)
        for k, problem in enumerate(designed_problems(args.designs)):
            rows += run_rows("design-300s", problem, args.first_seed + k, args.solvers)
            print(f"design {k + 1} done ({time.perf_counter() - t0:.0f} s)", flush=True)
    frame = pd.DataFrame(rows)
    if args.merge:
        earlier = pd.read_csv(args.merge, keep_default_na=False, na_values=[""])
        earlier["failed"] = earlier["failed"].fillna("").astype(str)
        order = list(dict.fromkeys(list(earlier["recipe"]) + list(frame["recipe"])))
        earlier_recipes = [r for r in dict.fromkeys(earlier["recipe"]) if r not in set(frame["recipe"])]
        frame = pd.concat([earlier[~earlier["recipe"].isin(frame["recipe"].unique())], frame], ignore_index=True)
        frame = frame.iloc[np.argsort([order.index(r) for r in frame["recipe"]], kind="stable")]
    frame.to_csv(out / "uncertainty-runs.csv", index=False)
    table, per_parameter = summary(frame)
    kept = f"; {', '.join(earlier_recipes)} kept from {Path(args.merge).name}" if args.merge else ""
    write_frame(table, out / "uncertainty-summary",
                title=f"Issue 40: per recipe and solver, no datasheet (seeds from {args.first_seed}; "
                f"{time.perf_counter() - t0:.0f} s{kept})")
    write_frame(per_parameter, out / "uncertainty-montecarlo",
                title="Issue 40: RMS of error/sigma (each run's own sigma) per recipe, solver and parameter")
    print(table.to_string(index=False))


if __name__ == "__main__":
    main()
