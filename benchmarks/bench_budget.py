"""Validate the covariance error budget against a Monte Carlo of simulated free-inertial navigation.

Run: ``python benchmarks/bench_budget.py [--runs 24] [--out results]``.  Each run draws parameter errors
from the paper's predicted calibration covariance, simulates a fresh 1 h static recording (5 min
alignment) with sensor noise, and navigates with the erroneous parameters.  The RMS north/east error
after 1 h is compared with the budget's total and, with the noise switched off and only the gyro-bias
errors drawn, with the gyro-bias contribution alone.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd
from casadi_sins.core import orientation
from casadi_sins.data.problem import load_problem
from casadi_sins.model import registry as R
from casadi_sins.nav.free_inertial import navigate_free
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate
from casadi_sins.studies.budget import error_budget
from casadi_sins.studies.navcheck import navigation_problem
from casadi_sins.studies.prediction import predict_problem



def one_run(args):
    seed, covariance, only = args
    problem = load_problem()
    if only is not None:
        problem = problem.with_changes(accel_noise_ug=0.0, gyro_noise_deg_h=0.0)
    sim = simulate(navigation_problem(problem), seed=seed)
    rng = np.random.default_rng(seed + 777)
    cov = covariance
    if only is not None:
        mask = np.zeros(R.N_PARAMS, bool)
        mask[only] = True
        cov = covariance * np.outer(mask, mask)
    delta = rng.multivariate_normal(np.zeros(R.N_PARAMS), cov)
    run = navigate_free(sim.recording, sim.truth.values + delta, 300.0, "mc")
    return run.north_m[-1], run.east_m[-1]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=24)
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    problem = load_problem()
    pred = predict_problem(problem)
    cov, nominal = pred.nominal.covariance, pred.nominal.values
    dev = problem.deviations
    budget = error_budget(cov, nominal, orientation.orientation_to_dcm("ENU"), problem.site.latitude, 0.0,
                          problem.site.g, dev.accel_noise_ug, dev.gyro_noise_deg_h, problem.rate_hz,
                          duration_s=3600.0)
    rows = []
    t0 = time.perf_counter()
    for label, only, predicted in (("total", None, budget.total[-1]),
                                   ("residual gyro bias alone", R.GYRO_BIAS,
                                    budget.contributions["residual gyro bias"][-1])):
        with ProcessPoolExecutor(2) as pool:
            ends = np.array(list(pool.map(one_run, [(s, cov, only) for s in range(args.runs)])))
        rms = np.sqrt(np.mean(ends**2, axis=0))
        rows.append({"source": label, "runs": args.runs, "mc rms north (m)": rms[0], "predicted north (m)": predicted[0],
                     "mc rms east (m)": rms[1], "predicted east (m)": predicted[1],
                     "ratio north": rms[0] / predicted[0], "ratio east": rms[1] / predicted[1]})
        print(rows[-1])
    frame = pd.DataFrame(rows)
    print(frame.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    print(f"{time.perf_counter() - t0:.0f} s; with {args.runs} runs an RMS has a sampling error of about "
          f"{100 / np.sqrt(2 * args.runs):.0f} %")
    write_frame(frame, f"{args.out}/budget-validation",
                "Error budget after 1 h against a Monte Carlo of free-inertial navigation")


if __name__ == "__main__":
    main()
