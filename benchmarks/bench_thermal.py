"""Thermal calibration end to end, against the truth at a temperature the fit never saw.

Run: ``python benchmarks/bench_thermal.py [--seeds 1 2 3] [--problem problems/thermal-kang2013.toml] [--out results]``.
Per seed: ``simulate`` the thermal problem (one recording per setpoint, each with its ``[conditions]
temperature_c``), ``batch`` calibrates them, ``thermal`` fits every table but the 10 degC one with
``--at 10``.  Measured: each parameter's error at 10 degC over its predicted sigma (z; target every
``|z| <= 4.5`` and ``sum z^2 <= 46.8``, the 99.9 % point of chi^2 with 21 degrees of freedom) and
each linear coefficient's error over its sigma (target ``|z| <= 4.5``).  Writes
``thermal-benchmark.{csv,md}`` (one row per seed) and prints the rows.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from casadi_sins.data.tables import read_table
from casadi_sins.data.thermal import read_thermal
from casadi_sins.data.thermal_problem import load_thermal_problem
from casadi_sins.report.tables import write_frame
from casadi_sins.studies.thermal.simulate import setpoint_name

LEFT_OUT_C = 10.0


def _cli(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "casadi_sins", *args], check=True, stdout=subprocess.DEVNULL)


def one_seed(problem: Path, seed: int, work: Path) -> dict:
    """Simulate, batch, fit without the left-out setpoint; the z of the table there and of the a1."""
    tp = load_thermal_problem(problem)
    sim, batch, fit = work / f"sim{seed}", work / f"batch{seed}", work / f"fit{seed}"
    _cli("simulate", str(problem), "--seed", str(seed), "--out", str(sim))
    _cli("batch", *sorted(str(p) for p in sim.glob("*.toml")), "--out", str(batch), "--workers", "1")
    tables = [str(batch / "units" / f"{setpoint_name(tp.problem.name, t)}.csv") for t in tp.setpoints_c
              if t != LEFT_OUT_C]
    _cli("thermal", *tables, "--at", f"{LEFT_OUT_C:g}", "--out", str(fit), "--no-plots")
    at = read_table(fit / f"at-{LEFT_OUT_C:g}C.csv")
    truth = read_table(sim / f"{setpoint_name(tp.problem.name, LEFT_OUT_C)}.truth.csv")
    z = (at.values - truth.aligned(at.names)) / at.sigma
    model = read_thermal(fit / "thermal.csv")
    za = (model.coefficients[:, 1] - tp.model.coefficients[:, 1]) / model.sigma[:, 1]
    return {"seed": seed, "max_abs_z_at_10C": float(np.abs(z).max()), "worst_parameter": at.names[int(np.argmax(
        np.abs(z)))], "sum_z2_at_10C": float(np.sum(z ** 2)), "max_abs_z_a1": float(np.abs(za).max()),
        "worst_a1": at.names[int(np.argmax(np.abs(za)))], "quadratic_parameters": int(np.sum(model.orders == 2)),
        "passes": bool(np.abs(z).max() <= 4.5 and np.sum(z ** 2) <= 46.8 and np.abs(za).max() <= 4.5)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--problem", default=str(Path(__file__).resolve().parents[1] / "problems" /
                                                 "thermal-kang2013.toml"))
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        rows = [one_seed(Path(args.problem), seed, Path(tmp)) for seed in args.seeds]
    frame = pd.DataFrame(rows)
    print(frame.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    write_frame(frame, Path(args.out) / "thermal-benchmark",
                "Thermal model: the table at 10 degC (left out of the fit) against its truth, per seed")


if __name__ == "__main__":
    main()
