"""The CasADi/Ipopt estimator: timings, Hessian variants, scaling, baseline, method error, Monte Carlo.

Run: ``python benchmarks/bench_nlp.py [--seeds 50] [--sections timing,hessian,scaling,baseline,blocks,mc]
[--out results]``.  Prints every figure and writes ``results/nlp-*.md`` / ``.csv``.

* timing    recording -> parameter table (graph construction included), NLP against ILS (targets: < 3 s,
            <= 2x ILS)
* hessian   Gauss-Newton against the exact Hessian and L-BFGS (time, iterations, same answer?)
* scaling   100 Hz against 400 Hz, 1x against 4x duration
* baseline  a plain scipy.optimize.least_squares fit (finite-difference Jacobian) of the same residuals,
            evaluated by the same compiled CasADi navigation: what a user would otherwise write
* blocks    method error of summing rotation samples into longer steps (noise-free recording)
* mc        Monte Carlo, both solvers on the same seeds: RMS error, sigma, floor, 4-sigma, NLP <= ILS
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
import pandas as pd
from casadi_sins.calibrate import calibrate_ils, calibrate_nlp
from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.calibrate.nlp.graph import build_graph, natural_to_parameters
from casadi_sins.calibrate.nlp.ipopt import quick_weights
from casadi_sins.data.problem import load_problem
from casadi_sins.model import registry as R
from casadi_sins.model.parameters import natural_errors
from casadi_sins.noise.plan import plan_noise
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate
from casadi_sins.studies import montecarlo as MC



def timed(fn, repeats=3):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def max_natural_error(values, truth):
    return float(np.abs(natural_errors(values, truth)).max())


def section_timing(problem, out):
    sim = simulate(problem, seed=1)
    t_nlp, res = timed(lambda: calibrate_nlp(sim.recording))
    t_ils, _ = timed(lambda: calibrate_ils(sim.recording))
    print(f"timing: nlp {t_nlp:.2f} s (graph {res.timings['graph']:.2f} s, {res.nit} Ipopt iterations), "
          f"ils {t_ils:.2f} s; nlp/ils {t_nlp / t_ils:.2f} (target <= 2), nlp/3 s target {t_nlp / 3:.2f}")
    return {"nlp_s": t_nlp, "ils_s": t_ils}


def section_hessian(problem, out):
    sim = simulate(problem, seed=1)
    rows = []
    for hessian in ("gauss-newton", "exact", "limited-memory"):
        try:
            t, res = timed(lambda: calibrate_nlp(sim.recording, hessian=hessian, use_rotation_steps=True), 1)
            err = natural_errors(res.parameters.values, sim.truth.values)
            rows.append({"hessian": hessian, "time (s)": t, "ipopt iterations": res.nit,
                         "max |error| (natural)": np.abs(err).max(), "rms error (natural)": np.sqrt(np.mean(err**2))})
        except Exception as exc:  # report, do not stop the benchmark
            rows.append({"hessian": hessian, "time (s)": np.nan, "ipopt iterations": np.nan,
                         "max |error| (natural)": np.nan, "rms error (natural)": np.nan, "failed": str(exc)})
    frame = pd.DataFrame(rows)
    print(frame.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    write_frame(frame, f"{out}/nlp-hessian", "NLP: Hessian variants on the paper's recording (seed 1)")


def section_scaling(problem, out):
    rows = []
    variants = {"100 Hz, 1x": problem,
                "400 Hz, 1x": dataclasses.replace(problem, rate_hz=400.0),
                "100 Hz, 4x": dataclasses.replace(problem, timing=dataclasses.replace(
                    problem.timing, static_s=4 * problem.timing.static_s, rotation_s=4 * problem.timing.rotation_s)),
                "400 Hz, 4x": None}
    variants["400 Hz, 4x"] = dataclasses.replace(variants["100 Hz, 4x"], rate_hz=400.0)
    for label, prob in variants.items():
        sim = simulate(prob, seed=1)
        t_nlp, res = timed(lambda: calibrate_nlp(sim.recording), 1)
        t_ils, _ = timed(lambda: calibrate_ils(sim.recording), 1)
        rows.append({"recording": label, "samples": len(sim.recording.time), "nlp (s)": t_nlp,
                     "nlp graph (s)": res.timings["graph"], "ils (s)": t_ils, "nlp/ils": t_nlp / t_ils})
        print(rows[-1])
    frame = pd.DataFrame(rows)
    frame["nlp / nlp(100 Hz, 1x)"] = frame["nlp (s)"] / frame["nlp (s)"].iloc[0]
    print(frame.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    write_frame(frame, f"{out}/nlp-scaling", "Time against rate and duration (one run each)")


def section_baseline(problem, out):
    from scipy.optimize import least_squares

    sim = simulate(problem, seed=1)
    rec = sim.recording
    t_nlp, res = timed(lambda: calibrate_nlp(rec, use_rotation_steps=True), 1)

    def baseline():
        reference = rough_parameters(rec).values
        built = build_graph(rec, reference)
        weights = quick_weights(built, plan_noise(rec, reference).model, rec.dt, True)  # the NLP's stage-1 weights
        fun = lambda z: weights @ np.asarray(built.residuals(z)).ravel()  # noqa: E731
        sol = least_squares(fun, np.zeros(built.n_variables), jac="2-point", method="trf", x_scale=1.0)
        return natural_to_parameters(sol.x[: R.N_PARAMS], reference), sol

    t_base, (values, sol) = timed(baseline, 1)
    print(f"baseline: scipy least_squares (2-point Jacobian over the compiled CasADi navigation) {t_base:.2f} s, "
          f"{sol.nfev} evaluations; nlp {t_nlp:.2f} s; nlp/baseline {t_nlp / t_base:.2f}; "
          f"max |error| baseline {max_natural_error(values, sim.truth.values):.3g}, "
          f"nlp {max_natural_error(res.parameters.values, sim.truth.values):.3g} (natural units)")
    write_frame(pd.DataFrame([{"nlp (s)": t_nlp, "scipy least_squares (s)": t_base, "nlp/scipy": t_nlp / t_base,
                               "scipy evaluations": sol.nfev}]), f"{out}/nlp-baseline",
                "NLP against a plain scipy.optimize.least_squares fit of the same residuals")


def section_blocks(problem, out):
    sim = simulate(problem.with_changes(start_attitude_deg=5.0), seed=1, noise=False)
    rows = []
    for block in (1, 2, 4, 5, 10):
        t, res = timed(lambda: calibrate_nlp(sim.recording, rotation_step_s=block / sim.recording.rate_hz,
                                             use_rotation_steps=True), 1)
        err = natural_errors(res.parameters.values, sim.truth.values)
        rows.append({"rotation step (samples)": block, "time (s)": t, "max |error| (natural)": np.abs(err).max(),
                     "worst parameter": R.NAMES[int(np.argmax(np.abs(err)))]})
    frame = pd.DataFrame(rows)
    print(frame.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    write_frame(frame, f"{out}/nlp-rotation-blocks",
                "Method error of summing rotation samples into longer steps (noise-free, 5 deg off nominal)")


def section_mc(problem, out, seeds):
    t0 = time.perf_counter()
    rows = MC.run(problem, range(5000, 5000 + seeds), ("nlp", "ils"),
                  progress=lambda k, n: print(f"\r  monte carlo {k}/{n}", end="", flush=True))
    print(f"\n{seeds} seeds, both solvers, {time.perf_counter() - t0:.0f} s")
    summary = MC.summary(rows)
    ok = rows[rows["failed"] == ""]
    pivot = ok.pivot_table(index=["seed", "parameter"], columns="solver", values="error").reset_index()
    worse = pivot.groupby("parameter").apply(
        lambda g: float(np.sqrt(np.mean(g["nlp"] ** 2)) / np.sqrt(np.mean(g["ils"] ** 2))), include_groups=False)
    summary["nlp_rms_over_ils_rms"] = summary["parameter"].map(worse)
    cols = ["solver", "parameter", "unit", "rms_error", "mean_sigma", "rms_over_sigma", "max_abs_z", "floor",
            "rms_over_floor", "paper", "nlp_rms_over_ils_rms"]
    pd.set_option("display.width", 220)
    print(summary[cols].to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    failed = rows[rows["failed"] != ""]
    print(f"failed runs: {len(failed)}")
    write_frame(summary[cols], f"{out}/montecarlo-paper",
                f"Monte Carlo of the paper's problem, {seeds} seeds, both solvers on the same recordings")
    write_frame(rows, f"{out}/montecarlo-paper-runs")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=50)
    parser.add_argument("--sections", default="timing,hessian,scaling,baseline,blocks,mc")
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    problem = load_problem()
    for section in args.sections.split(","):
        print(f"== {section}")
        if section == "mc":
            section_mc(problem, args.out, args.seeds)
        else:
            globals()[f"section_{section}"](problem, args.out)


if __name__ == "__main__":
    main()
