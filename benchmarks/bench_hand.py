"""Sessions by hand without a turntable (issue 37): speed, agreement with IMU-TK, honesty over seeds.

Run: ``python benchmarks/bench_hand.py [--runs 3] [--seeds 1 2 3 4 5 6 7 8] [--out results]`` (about 10 min on an
idle 2-core machine).  Every calibration is ``casadi-sins segment`` then ``casadi-sins calibrate`` with the
defaults, each a whole process (start-up, imports and compiled-library loads included), as a user runs them.

1. **Speed.**  A 10-minute session at 100 Hz (``problems/hand-mems.toml`` with 48 rests: 622 s) and IMU-TK's
   Xsens session (``tests/fixtures/imu_tk-xsens``, 512 s), each segmented and calibrated ``--runs`` times after
   one warm-up run (the first run on a machine compiles the model's libraries, about 10 s of CPU once): the
   median wall time of each process and of the two together (the bar: 30 s on 2 cores).
2. **IMU-TK.**  Our table of its session against IMU-TK's own (``imu_tk-calibration.csv``): value, sigma,
   difference in sigma and, for the scale factors, relative (``results/hand-imu_tk-xsens.csv`` and ``.md``).
3. **Honesty.**  ``problems/hand-mems.toml`` and the same with a gyro g-sensitivity in its truth, over ``--seeds``:
   the largest |error/sigma| of the 21 and their joint chi-square (99.8 % band 6.4-46.8 when the covariance is
   honest), written to ``results/hand-sessions.csv`` and ``.md``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from casadi_sins.data.problem import load_problem
from casadi_sins.data.tables import read_table
from casadi_sins.model.parameters import ParameterSet, joint_chi_square, natural_errors
from casadi_sins.model.registry import NAMES
from casadi_sins.report.tables import markdown_table
from casadi_sins.sim import simulate, write_simulation

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "hand-mems.toml"
XSENS = ROOT / "tests" / "fixtures" / "imu_tk-xsens"
#: A MEMS gyro g-sensitivity (rad/s per m/s^2; about 0.1 deg/s per g), for the second set of seeds.
G_SENSITIVITY = {f"gyro_gsens_{i}{j}": v for (i, j), v in zip(
    [(i, j) for i in "xyz" for j in "xyz"], [1.2e-4, -0.8e-4, 0.5e-4, 0.6e-4, -1.5e-4, 0.9e-4, -0.4e-4, 1.0e-4, 0.7e-4])}


def command(*args) -> float:
    """Run ``casadi-sins ARGS`` as its own process; its wall time (s)."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "casadi_sins", *map(str, args)], capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"casadi-sins {' '.join(map(str, args))} failed: {done.stderr.strip()}")
    return time.perf_counter() - start


def segment_args(csv: Path, site: tuple[float, float]) -> list:
    return [csv, "--rate", "100", "--latitude", site[0], "--height", site[1]]


def session(data: list, folder: Path, name: str, truth: Path | None = None) -> tuple[float, float, Path]:
    """Segment and calibrate one session: ``(segment s, calibrate s, table)``."""
    described, table = folder / f"{name}-found.toml", folder / f"{name}-table.csv"
    seconds = command("segment", *data, "--out", described)
    extra = ["--truth", truth] if truth else []
    return seconds, command("calibrate", described, "--out", table, "--quiet", *extra), table


def timing(runs: int, folder: Path) -> pd.DataFrame:
    problem = load_problem(PROBLEM)
    ten = dataclasses.replace(problem, name="hand-10min", hand=dataclasses.replace(problem.hand, rests=48))
    csv = write_simulation(simulate(ten, seed=5), folder).with_suffix(".csv")
    cases = {f"simulated, {ten.duration:.0f} s at 100 Hz": segment_args(csv, (45.4, 12.0)),
             "IMU-TK's Xsens session, 512 s at 100.01 Hz": [XSENS / "xsens.toml"]}
    rows = []
    for label, data in cases.items():
        session(data, folder, "timed")  # a warm-up, not counted: the first run compiles the model's libraries
        times = [session(data, folder, "timed")[:2] for _ in range(runs)]
        segment, calibrate = (statistics.median(t[k] for t in times) for k in (0, 1))
        rows.append({"session": label, "runs": runs, "segment (s)": segment, "calibrate (s)": calibrate,
                     "whole (s)": statistics.median(sum(t[:2]) for t in times)})
        print(f"{label}: segment {segment:.2f} s, calibrate {calibrate:.2f} s (medians of {runs} whole processes)")
    return pd.DataFrame(rows)


def imu_tk(folder: Path) -> pd.DataFrame:
    _, _, table = session([XSENS / "xsens.toml"], folder, "xsens")
    ours, theirs = read_table(table), read_table(XSENS / "imu_tk-calibration.csv")
    frame = pd.DataFrame({"parameter": NAMES, "ours": ours.values[:21], "sigma": ours.sigma[:21],
                          "IMU-TK": theirs.values})
    frame["(ours - IMU-TK) / sigma"] = (frame["ours"] - frame["IMU-TK"]) / frame["sigma"]
    frame["ours / IMU-TK - 1 (scale factors)"] = [o / t - 1.0 if "scale" in n else np.nan
                                                  for n, o, t in zip(NAMES, frame["ours"], frame["IMU-TK"])]
    print(frame.to_string(index=False))
    return frame


def honesty(seeds: list[int], folder: Path) -> pd.DataFrame:
    plain = load_problem(PROBLEM)
    truth = dict(plain.truth.as_dict(), **G_SENSITIVITY)
    sensitive = dataclasses.replace(plain, name="hand-mems-gsens", truth=ParameterSet.from_dict(truth))
    rows = []
    for problem in (plain, sensitive):
        for seed in seeds:
            sim = simulate(problem, seed=seed)
            csv = write_simulation(sim, folder).with_suffix(".csv")
            _, seconds, table = session(segment_args(csv, (45.4, 12.0)), folder, csv.stem,
                                        csv.with_suffix(".truth.csv"))
            ours = read_table(table)
            report = json.loads(table.with_name(table.stem + ".report.json").read_text())
            z = natural_errors(ours, sim.truth)[:21] / ours.natural_sigma()[:21]
            covariance = np.array(report["covariance"])[:21, :21]
            chi = joint_chi_square(ParameterSet(ours.values[:21], covariance=covariance), sim.truth)
            worst = int(np.argmax(np.abs(z)))
            rows.append({"problem": problem.name, "seed": seed, "max |error/sigma|": float(np.abs(z[worst])),
                         "worst": NAMES[worst], "joint chi-square (21)": chi, "in band": 6.4 <= chi <= 46.8,
                         "calibrate (s)": seconds, "warnings": len(report["warnings"])})
            print(rows[-1])
    return pd.DataFrame(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 9)))
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        speed = timing(args.runs, folder)
        table = imu_tk(folder)
        seeds = honesty(args.seeds, folder)
    table.to_csv(out / "hand-imu_tk-xsens.csv", index=False)
    seeds.to_csv(out / "hand-sessions.csv", index=False)
    z = table["(ours - IMU-TK) / sigma"].abs()
    share = table["ours / IMU-TK - 1 (scale factors)"].abs()
    accel_worst, gyro_scale = z[:9].max(), (z[12:15].where(share[12:15] > 0.002, 0.0)).max()
    lines = ["# Sessions by hand (issue 37)", "",
             "`casadi-sins segment` then `casadi-sins calibrate` with the defaults, each a whole process "
             "(`benchmarks/bench_hand.py`).", "", "## Speed (medians of whole processes)", "",
             markdown_table(speed, "%.3g"), "",
             "## IMU-TK's Xsens session against IMU-TK's own table", "",
             f"Accelerometer biases, scale factors and misalignments: largest |difference| {accel_worst:.2f} sigma; "
             f"gyro scale factors: every one within 4.5 sigma or 0.2 % ({gyro_scale:.2f} sigma beyond 0.2 %). IMU-TK "
             "takes the gyro biases from the first rest and has no gyro g-sensitivity (the fixture's README): its "
             "gyro biases and misalignments are shown, not judged.", "", markdown_table(table, "%.6g"), "",
             "## Simulated sessions by hand against their truth", "",
             f"{int(seeds['in band'].sum())} of {len(seeds)} joint chi-squares in the 99.8 % band; largest "
             f"|error/sigma| {seeds['max |error/sigma|'].max():.2f}.", "", markdown_table(seeds, "%.3g"), ""]
    (out / "hand-sessions.md").write_text("\n".join(lines))
    speed.to_csv(out / "hand-speed.csv", index=False)
    print(f"wrote {out}/hand-sessions.md, hand-sessions.csv, hand-imu_tk-xsens.csv, hand-speed.csv")


if __name__ == "__main__":
    main()
