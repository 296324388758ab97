"""``casadi-sins noise`` on an 8 h recording at 400 Hz (issue 36): the whole process timed, the recovered terms
against the truth; and the same on the package's own simulator.

Run: ``python benchmarks/bench_noise_identification.py [--hours 8] [--rate 400] [--work /tmp/noise-bench]
[--out results]`` (the first run writes the 1.1 GB recording, a few minutes; later runs reuse it).

The recording is made here with NumPy alone, not with the package's simulator: per axis white noise, a
first-order Gauss-Markov bias (an AR(1) per sample) and, on some axes, quantization of the accumulated angle,
with correlation times from 200 s to 1000 s and Gauss-Markov sigmas from 0.8 (gyro y: too faint to see in 8 h, bounded) to 3 times the white noise's Allan
deviation at the correlation time; pulses of the paper's sizes as floats, a description without segments (all at
rest) and a table with the scale factors (``--params``).  The second part simulates a problem with one static
segment and a bias instability (``casadi-sins simulate``) and identifies it with its truth table.

Prints, and writes ``OUT/noise-identification.{md,csv}``: per axis the truth, the estimate, its ratio and the
bar of issue 36 (white within 10 %, Gauss-Markov sigma within 40 %, correlation time within a factor 2), and the
whole process's wall and CPU time (the bar: 60 s).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

DEG, UG = np.pi / 180.0, 9.80665e-6
AXES = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
PULSE = np.array([9.8e-8, 9.9e-8, 9.7e-8, 3.4e-4, 3.5e-4, 3.3e-4])  # rad/pulse, m/s/pulse
WHITE = np.array([0.002, 0.003, 0.0025, 15.0, 20.0, 12.0]) * np.array([DEG / 60] * 3 + [UG] * 3)
SIGMA = np.array([0.01, 0.006, 0.015, 2.0, 3.0, 1.5]) * np.array([DEG / 3600] * 3 + [UG] * 3)
TAU = np.array([300.0, 600.0, 900.0, 200.0, 700.0, 1000.0])
QUANT = np.array([0.5, 0.0, 0.3, 0.0, 0.2, 0.0]) * PULSE
MEAN = np.array([4.2e-5, 3e-5, 5e-5, 0.01, 0.02, 9.80])  # Earth rate and bias, gravity: rad/s, m/s^2
NATURAL = np.array([DEG / 60] * 3 + [UG] * 3), np.array([DEG / 3600] * 3 + [UG] * 3)
TABLE = {**{k: ("m/s^2", 0.0) for k in ("accel_bias_x", "accel_bias_y", "accel_bias_z")},
         **{k: ("rad", 0.0) for k in ("accel_misalign_yx", "accel_misalign_zx", "accel_misalign_zy")},
         **{f"gyro_bias_{a}": ("rad/s", 0.0) for a in "xyz"},
         **{f"gyro_misalign_{k}": ("rad", 0.0) for k in ("xy", "xz", "yx", "yz", "zx", "zy")},
         **{f"gyro_scale_{a}": ("rad/pulse", float(PULSE[i])) for i, a in enumerate("xyz")},
         **{f"accel_scale_{a}": ("m/s/pulse", float(PULSE[3 + i])) for i, a in enumerate("xyz")}}


def write_recording(work: Path, hours: float, rate: float, seed: int = 7) -> Path:
    """The independent recording (module docstring), unless already written."""
    toml = work / f"static-{hours:g}h-{rate:g}hz.toml"
    csv = toml.with_suffix(".csv")
    if toml.exists() and csv.exists():
        return toml
    from scipy.signal import lfilter
    work.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    dt, n = 1.0 / rate, int(round(hours * 3600 * rate))
    a = np.exp(-dt / TAU)
    bias, remainder = rng.standard_normal(6) * SIGMA, rng.standard_normal(6) * QUANT
    part = csv.with_suffix(".part")
    with open(part, "w") as handle:
        handle.write("time," + ",".join(AXES) + "\n")
        for start in range(0, n, 400_000):
            m = min(400_000, n - start)
            b = np.empty((m, 6))
            for i in range(6):
                drive = rng.standard_normal(m) * SIGMA[i] * np.sqrt(1 - a[i] ** 2)
                b[:, i] = lfilter([1.0], [1.0, -a[i]], drive, zi=[a[i] * bias[i]])[0]
            bias = b[-1]
            e = rng.standard_normal((m, 6)) * QUANT
            q = np.diff(np.vstack([remainder, e]), axis=0)
            remainder = e[-1]
            increments = (MEAN + b) * dt + WHITE * np.sqrt(dt) * rng.standard_normal((m, 6)) + q
            frame = pd.DataFrame(increments / PULSE, columns=AXES)
            frame.insert(0, "time", np.round((np.arange(start, start + m) + 1) * dt, 9))
            handle.write(frame.to_csv(index=False, header=False, lineterminator="\n", float_format="%.12g"))
            print(f"  written {start + m} of {n} samples", file=sys.stderr, flush=True)
    os.replace(part, csv)
    toml.write_text(f'format = "sins-recording/1"\nname = "{toml.stem}"\ndata = "{csv.name}"\n[site]\n'
                    f'latitude_deg = 37.5\nheight_m = 0.0\n[imu]\nrate_hz = {rate}\n')
    (work / "scale.csv").write_text("parameter,unit,value\n" + "".join(f"{k},{u},{v!r}\n" for k, (u, v) in TABLE.items()))
    return toml


def run_noise(args: list[str]) -> tuple[float, float, dict]:
    """The whole process ``casadi-sins noise ARGS``: wall seconds, CPU seconds, its JSON."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "casadi_sins", "noise", *args, "--no-progress"], check=True,
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    out = Path(args[args.index("--out") + 1])
    return wall, cpu, json.loads((out / "noise.json").read_text())


def compare(doc: dict, white, sigma, tau, source: str) -> pd.DataFrame:
    """Per axis: truth, estimate, ratio, and whether it meets the issue's bar."""
    rows = []
    for i, axis in enumerate(AXES):
        entry = doc["axes"][axis]
        ml = entry["maximum_likelihood"]
        est_white = entry["white"]["value"] * NATURAL[0][i]
        est_sigma = (ml["sigma"] or 0.0) * NATURAL[1][i]
        est_tau = ml["tau_s"] or np.nan
        rows.append({"source": source, "axis": axis, "white_truth": white[i] / NATURAL[0][i],
                     "white": est_white / NATURAL[0][i], "white_ratio": est_white / white[i],
                     "sigma_truth": sigma[i] / NATURAL[1][i], "sigma": est_sigma / NATURAL[1][i],
                     "sigma_ratio": est_sigma / sigma[i], "tau_truth": tau[i], "tau": est_tau,
                     "tau_ratio": est_tau / tau[i], "status": entry["gauss_markov"],
                     "bar": bool(abs(est_white / white[i] - 1) <= 0.1 and abs(est_sigma / sigma[i] - 1) <= 0.4
                                 and 0.5 <= est_tau / tau[i] <= 2.0)})
    return pd.DataFrame(rows)


def simulator_case(work: Path) -> tuple[float, float, pd.DataFrame]:
    """The package's simulator: one static segment of 8 h at 100 Hz with a bias instability."""
    problem = work / "static-sim.toml"
    truth_rows = Path(__file__).resolve().parents[1] / "casadi_sins" / "problems" / "long-10h-400hz.toml"
    truth = truth_rows.read_text().split("[truth]", 1)[1]
    problem.write_text('format = "casadi-sins-problem/1"\nname = "static-sim"\n[site]\nlatitude_deg = 37.5\n'
                       'height_m = 0.0\n[imu]\nrate_hz = 100.0\n[timing]\nstatic_s = 28800.0\nrotation_s = 10.0\n'
                       '[[groups]]\nstart = "NUE"\nrotations = []\n[errors]\nstart_attitude_deg = 0.4\n'
                       'accel_noise_ug = 0.0\ngyro_noise_deg_h = 0.0\naccel_vrw_ug_rthz = 15.0\n'
                       'gyro_arw_deg_rth = 0.002\ngyro_bias_instability_deg_h = 0.01\ngyro_bias_tau_s = 300.0\n'
                       'accel_bias_instability_ug = 3.0\naccel_bias_tau_s = 600.0\n[truth]' + truth)
    rec = work / "sim" / "static-sim-seed1.toml"
    if not rec.exists():
        subprocess.run([sys.executable, "-m", "casadi_sins", "simulate", str(problem), "--seed", "1", "--out",
                        str(work / "sim"), "--no-progress"], check=True, stdout=subprocess.DEVNULL)
    wall, cpu, doc = run_noise([str(rec), "--params", str(rec.with_suffix(".truth.csv")), "--out",
                                str(work / "sim-noise")])
    white = np.array([0.002 * DEG / 60] * 3 + [15.0 * UG] * 3)
    sigma = np.array([0.01 * DEG / 3600] * 3 + [3.0 * UG] * 3)
    return wall, cpu, compare(doc, white, sigma, np.array([300.0] * 3 + [600.0] * 3), "simulate")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=8.0)
    parser.add_argument("--rate", type=float, default=400.0)
    parser.add_argument("--work", default="/tmp/noise-bench", help="where the recordings are written (kept)")
    parser.add_argument("--out", default="results")
    parser.add_argument("--no-simulator", action="store_true", help="leave out the package's simulator")
    args = parser.parse_args()
    work = Path(args.work)
    toml = write_recording(work, args.hours, args.rate)
    size = toml.with_suffix(".csv").stat().st_size
    wall, cpu, doc = run_noise([str(toml), "--params", str(work / "scale.csv"), "--out", str(work / "noise")])
    table = compare(doc, WHITE, SIGMA, TAU, "independent")
    lines = [f"# casadi-sins noise on {args.hours:g} h at {args.rate:g} Hz (issue 36)", "",
             f"Independent recording (NumPy): {doc['samples']} samples, {size / 1e9:.2f} GB of CSV; whole process "
             f"{wall:.1f} s wall, {cpu:.1f} s CPU (bar: 60 s); load average at the end "
             f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores.", ""]
    if not args.no_simulator:
        sim_wall, sim_cpu, sim_table = simulator_case(work)
        table = pd.concat([table, sim_table], ignore_index=True)
        lines += [f"The package's simulator (`casadi-sins simulate`, one static segment of 8 h at 100 Hz, bias "
                  f"instability 0.01 deg/h over 300 s and 3 ug over 600 s): {sim_wall:.1f} s wall, {sim_cpu:.1f} s "
                  "CPU.", ""]
    lines += ["White noise: deg/sqrt(h) (gyros), ug/sqrt(Hz) (accelerometers); Gauss-Markov sigma: deg/h, ug; "
              "tau: s. The estimate is the maximum likelihood (also where the record does not bound tau: "
              "status `tau beyond reach`). Bar: white within 10 %, sigma within 40 %, tau within a factor 2.", "",
              "| source | axis | white truth | white | ratio | sigma truth | sigma | ratio | tau truth | tau | ratio | "
              "status | bar |", "| --- " * 13 + "|"]
    for row in table.itertuples():
        lines.append(f"| {row.source} | {row.axis} | {row.white_truth:.4g} | {row.white:.4g} | {row.white_ratio:.3f} | "
                     f"{row.sigma_truth:.3g} | {row.sigma:.3g} | {row.sigma_ratio:.2f} | {row.tau_truth:.0f} | "
                     f"{row.tau:.0f} | {row.tau_ratio:.2f} | {row.status} | {'yes' if row.bar else 'no'} |")
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "noise-identification.md").write_text(text)
    table.to_csv(out / "noise-identification.csv", index=False, float_format="%.6g")


if __name__ == "__main__":
    main()
