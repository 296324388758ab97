"""Gyro g-sensitivity and scale-factor asymmetry (issue 26): the bar on ``problems/extended-gsens.toml``.

Per seed: ``--model auto`` (the groups kept, every error in sigma, the sum of z^2 over the 33 against
63.9, the largest gyro-bias error) and the default 21 terms (whether a warning names ``--model auto``,
its gyro-bias sigma), with the wall time of each.

Run: ``python benchmarks/bench_gyro_groups.py [--seeds 0 1 2] [--out results]`` (a few minutes per seed on
one core).  Writes ``results/gyro-groups.{csv,md}``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd
from casadi_sins.calibrate import calibrate_nlp
from casadi_sins.core.units import DEG_PER_H
from casadi_sins.data.problem import load_problem
from casadi_sins.model import registry as R
from casadi_sins.model.parameters import natural_errors
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate

ROOT = Path(__file__).resolve().parents[1]
GYRO_BIAS = [R.NAMES.index(f"gyro_bias_{a}") for a in "xyz"]


def one_seed(problem, seed: int) -> dict:
    sim = simulate(problem, seed=seed)
    t0 = time.perf_counter()
    auto = calibrate_nlp(sim.recording, model="auto")
    t_auto = time.perf_counter() - t0
    z = natural_errors(auto.parameters, sim.truth) / auto.parameters.natural_sigma()
    t0 = time.perf_counter()
    plain = calibrate_nlp(sim.recording)
    t_21 = time.perf_counter() - t0
    bias_error = np.abs(auto.parameters.values[GYRO_BIAS] - sim.truth.core[GYRO_BIAS]) / DEG_PER_H
    return {"seed": seed, "auto groups": " ".join(auto.nlp.model), "parameters": len(auto.parameters.names),
            "max |z|": float(np.abs(z).max()), "sum z^2": float(np.sum(z**2)),
            "gyro bias error max (deg/h)": float(bias_error.max()),
            "gyro bias sigma (deg/h)": float(auto.parameters.natural_sigma()[GYRO_BIAS].max()),
            "21: warning names --model auto": any("--model auto" in w for w in plain.warnings),
            "21: gyro bias sigma (deg/h)": float(plain.parameters.natural_sigma()[GYRO_BIAS].max()),
            "auto time (s)": t_auto, "21 time (s)": t_21}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--out", default=str(ROOT / "results"))
    args = parser.parse_args()
    problem = load_problem(ROOT / "problems" / "extended-gsens.toml")
    frame = pd.DataFrame([one_seed(problem, s) for s in args.seeds])
    write_frame(frame, Path(args.out) / "gyro-groups",
                "extended-gsens: --model auto against the bar (33 errors within 4.5 sigma, sum z^2 <= 63.9, "
                "gyro bias <= 5e-4 deg/h) and the 21 terms' warning")
    print(frame.to_string(index=False))


if __name__ == "__main__":
    main()
