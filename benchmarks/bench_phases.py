"""Speed of the main job: recording -> parameter table, by phase, and against the ILS (issue 11).

Run: ``python benchmarks/bench_phases.py [--repeats 3] [--out results]``.  Times, in fresh processes on
one core (BLAS held to one thread): the import, reading the recording, the raw-data noise estimate,
building the graph, Ipopt with the generalised least squares, the checks and covariance, writing the
table and its report; then the same recording through the ILS.  Writes ``results/main-job-phases.{csv,md}``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd

from casadi_sins.data.description import write_recording
from casadi_sins.data.problem import load_problem
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate

CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
from casadi_sins.calibrate import calibrate
from casadi_sins.core.files import write_files
from casadi_sins.data.description import read_recording
from casadi_sins.data.tables import table_text
from casadi_sins.report.calibration import report_files
t1 = time.perf_counter()
rec = read_recording(sys.argv[1])
t2 = time.perf_counter()
result = calibrate(rec, solver=sys.argv[2])
t3 = time.perf_counter()
files = {sys.argv[3]: table_text(result.parameters).encode()}
files.update(report_files(result, rec, sys.argv[3]))
write_files(files)
t4 = time.perf_counter()
out = {"import": t1 - t0, "read": t2 - t1, "calibrate": t3 - t2, "write": t4 - t3, "total": t4 - t0}
out.update(result.timings)
print(json.dumps(out))
"""


def run(recording: Path, solver: str, out: Path) -> dict:
    env = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "PATH": "/usr/bin:/bin"}
    done = subprocess.run(["taskset", "-c", "0", sys.executable, "-c", CHILD, str(recording), solver, str(out)],
                          capture_output=True, text=True, env={**env, **dict(__import__("os").environ)})
    if done.returncode:
        raise RuntimeError(done.stderr)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "results"))
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        path = write_recording(simulate(load_problem(), seed=1).recording, Path(tmp) / "kang2013-seed1.toml")
        rows = []
        for solver in ("nlp", "ils"):
            runs = [run(path, solver, Path(tmp) / f"{solver}.csv") for _ in range(args.repeats)]
            best = min(runs, key=lambda r: r["total"])
            rows.append({"solver": solver, **{k: round(v, 3) for k, v in best.items()}})
            print(solver, best)
    frame = pd.DataFrame(rows)
    ratio = frame.loc[0, "total"] / frame.loc[1, "total"]
    print(f"NLP / ILS, whole process: {ratio:.2f}")

    write_frame(frame, f"{args.out}/main-job-phases", "The paper's recording -> table and report, one core, best of "
                f"{args.repeats} fresh processes (s); NLP / ILS {ratio:.2f}")


if __name__ == "__main__":
    main()
