"""Speed of the whole process (issue 18): fresh ``casadi-sins calibrate`` processes on one core, by case.

Run: ``python benchmarks/bench_speed.py [--repeats 5] [--baseline DIR] [--out results]``.

Cases (simulated with seed 7 into ``--work``, default a temporary folder): the paper's recording with
the NLP and the ILS, the navigation-grade 200 Hz file (``benchmarks/navgrade-200hz.toml``, 402,000
samples), the swaying base, and the 19-position peer file with ``--model extended``.  Each is timed
as ``python -m casadi_sins calibrate`` in fresh processes, CPU time (user + system, children included)
with one BLAS thread and the process pinned to one core where ``taskset`` exists, median of
``--repeats``; with ``--baseline DIR`` (another checkout, e.g. of main) the two trees alternate, run by
run, and the values and sigmas of their tables are compared (also on a quantized recording).
Python's bytecode is cached in a separate folder (as an installed package has it).  Then: the phases
of one in-process calibration, the ratios against the paper's NLP, the Monte Carlo throughput (runs
per minute per core, sequentially, both solvers) and the time to its first finished run with two
workers, the first run with an empty compile cache, and a run without compiling
(``CASADI_SINS_NO_COMPILE=1``).  Writes ``results/speed.{csv,md}``.  Not a test: timings depend on the
machine and on what else runs (the load average is printed).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
TREE = HERE.parent
PEER = TREE / "tests" / "fixtures" / "psins-19pos" / "psins-19pos.toml"
CASES = {  # name: (recording, extra arguments)
    "paper NLP": ("kang2013-seed7.toml", ["--solver", "nlp"]),
    "paper ILS": ("kang2013-seed7.toml", ["--solver", "ils"]),
    "navigation-grade 200 Hz NLP": ("navgrade-200hz-seed7.toml", ["--solver", "nlp"]),
    "swaying base NLP": ("kang2013-sway-seed7.toml", ["--solver", "nlp"]),
    "deck NLP": ("kang2013-deck-seed7.toml", ["--solver", "nlp"]),
    "19-position peer, extended NLP": (str(PEER), ["--solver", "nlp", "--model", "extended"]),
}
#: Compared for the results only (not timed).
CHECKED = {"quantized NLP": ("kang2013-quantized-seed7.toml", ["--solver", "nlp"])}
TARGETS = {"paper NLP": 1.0, "paper ILS": 2.0}  # s
RATIO_TARGETS = {"19-position peer, extended NLP": 3.0, "swaying base NLP": 2.0, "deck NLP": 2.0,
                 "navigation-grade 200 Hz NLP": 1.5}


def simulate_recordings(work: Path) -> None:
    """The benchmark's recordings (seed 7), unless already there."""
    problems = {"kang2013-seed7.toml": TREE / "problems" / "kang2013.toml",
                "kang2013-deck-seed7.toml": TREE / "problems" / "kang2013-deck.toml",
                "navgrade-200hz-seed7.toml": HERE / "navgrade-200hz.toml"}
    text = (TREE / "problems" / "kang2013.toml").read_text()
    variants = {"kang2013-sway-seed7.toml": ('name = "kang2013-sway"', "quantize = false\nsway_amplitude_arcsec = "
                                             "[20.0, 120.0]\nsway_period_s = [2.0, 20.0]"),
                "kang2013-quantized-seed7.toml": ('name = "kang2013-quantized"', "quantize = true")}
    for name, (title, errors) in variants.items():
        path = work / name.replace("-seed7", "")
        path.write_text(text.replace('name = "kang2013"', title).replace("quantize = false", errors))
        problems[name] = path
    for name, problem in problems.items():
        if not (work / name).exists():
            subprocess.run([sys.executable, "-m", "casadi_sins", "simulate", str(problem), "--seed", "7", "--out",
                            str(work)], check=True, capture_output=True, env=environment(TREE, work))


def environment(tree: Path, work: Path, **extra) -> dict:
    """One BLAS thread, the tree's package, bytecode cached outside the tree, the compile cache in ``work``."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", PYTHONPATH=str(tree),
               PYTHONPYCACHEPREFIX=str(work / "pycache" / tree.name), CASADI_SINS_CACHE=str(work / "cache"))
    env.update(extra)
    return env


def timed(command: list[str], env: dict) -> tuple[float, float, str]:
    """``(CPU s, wall s, stderr)`` of a command (CPU of its process tree, pinned to one core if possible)."""
    if shutil.which("taskset"):
        command = ["taskset", "-c", str(os.cpu_count() - 1), *command]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0,):
        raise RuntimeError(f"{' '.join(command)} failed: {done.stderr[-2000:]}")
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, wall, done.stderr


def calibrate_command(work: Path, recording: str, args: list[str], out: Path) -> list[str]:
    return [sys.executable, "-m", "casadi_sins", "calibrate", str(work / recording), *args, "--out", str(out)]


def whole_processes(trees: dict, work: Path, repeats: int, cases: dict) -> dict:
    """CPU and wall times per case and tree, the trees alternating run by run (a warm-up run first)."""
    out = {}
    for case, (recording, args) in cases.items():
        out[case] = {name: {"cpu": [], "wall": []} for name in trees}
        for run in range(repeats + 1):
            for name, tree in trees.items():
                table = work / "tables" / name / f"{case.replace(' ', '_').replace(',', '')}.csv"
                table.parent.mkdir(parents=True, exist_ok=True)
                cpu, wall, _ = timed(calibrate_command(work, recording, args, table), environment(tree, work))
                if run:  # the first run warms bytecode and compile caches
                    out[case][name]["cpu"].append(cpu)
                    out[case][name]["wall"].append(wall)
        if not repeats:
            continue
        medians = {name: statistics.median(v["cpu"]) for name, v in out[case].items()}
        print(f"{case:32s} " + "  ".join(f"{n} {m:6.3f} s" for n, m in medians.items()) + f"  (load {os.getloadavg()[0]:.2f})",
              flush=True)
    return out


def table_differences(work: Path, trees: dict) -> dict:
    """Max |value difference| / sigma and |sigma difference| / sigma between the trees' tables, per case."""
    sys.path.insert(0, str(TREE))
    from casadi_sins.data.tables import read_table

    names = list(trees)
    out = {}
    for case in list(CASES) + list(CHECKED):
        stem = f"{case.replace(' ', '_').replace(',', '')}.csv"
        a, b = (read_table(work / "tables" / name / stem) for name in names)
        sigma = a.sigma
        out[case] = (float(max(abs(a.values - b.values) / sigma)), float(max(abs(a.sigma - b.sigma) / sigma)))
    return out


PHASES = r"""
import json, sys, time
t0 = time.process_time()
from casadi_sins.calibrate import calibrate_ils, calibrate_nlp
from casadi_sins.data.description import read_recording
t1 = time.process_time()
rec = read_recording(sys.argv[1])
t2 = time.process_time()
nlp = calibrate_nlp(rec)
t3 = time.process_time()
calibrate_ils(rec)
t4 = time.process_time()
print(json.dumps({"import": t1 - t0, "read": t2 - t1, "nlp": t3 - t2, "ils": t4 - t3, "nlp phases (wall)": nlp.timings}))
"""

ROUTES = r"""
import json, sys, time
import numpy as np
from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.calibrate.nlp.graph import build_graph
from casadi_sins.calibrate.steps import default_observation_spacing
from casadi_sins.data.description import read_recording
from casadi_sins.noise.kalman import NoiseSystem
from casadi_sins.noise.plan import plan_noise
rec = read_recording(sys.argv[1])
ref = rough_parameters(rec).values
t = time.process_time(); g = build_graph(rec, ref, default_observation_spacing(rec)); build = time.process_time() - t
z = np.zeros(g.n_variables)
def jacobian(z):
    g.__dict__["_last"] = None  # no kept linearisation: time the evaluation
    return [np.asarray(m) for m in g.jacobian(z)]
jacobian(z)
t = time.process_time()
for i in range(5): jacobian(z + i * 1e-9)
jac = (time.process_time() - t) / 5
t = time.process_time()
for i in range(5): np.asarray(g.residuals(z + i * 1e-8))
res = (time.process_time() - t) / 5
r, J = jacobian(z)
system = NoiseSystem(g.tracks(np.asarray(g.trajectory(z)), True), rec.site.g, rec.site.earth_rate)
model = plan_noise(rec, ref).model
system.whiten(np.column_stack([r.ravel(), J]), model)
t = time.process_time(); system.whiten(np.column_stack([r.ravel(), J]), model); white = time.process_time() - t
print(json.dumps({"graph build s": build, "Jacobian ms": 1e3 * jac, "residuals ms": 1e3 * res,
                  "whitening [r, J] ms": 1e3 * white}))
"""

MONTE_CARLO = r"""
import json, sys, time
t0 = time.perf_counter()
from casadi_sins.data.problem import load_problem
from casadi_sins.studies import montecarlo as MC
first = []
runs, workers = int(sys.argv[1]), int(sys.argv[2])
MC.run(load_problem(), range(100, 100 + runs), ("nlp", "ils"), workers=workers,
       progress=lambda done, total: first.append(time.perf_counter() - t0) if not first else None)
print(json.dumps({"first": first[0], "total": time.perf_counter() - t0}))
"""


def child_json(code: str, args: list[str], env: dict) -> tuple[dict, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return json.loads(done.stdout.strip().splitlines()[-1]), cpu


def monte_carlo(trees: dict, work: Path, runs: int) -> dict:
    """Per tree: runs per minute per core (one worker, both solvers, CPU time of the process), and the time to
    the first finished run with two workers."""
    out = {}
    for name, tree in trees.items():
        env = environment(tree, work)
        sequential, cpu = child_json(MONTE_CARLO, [str(runs), "1"], env)
        parallel, _ = child_json(MONTE_CARLO, [str(max(2, runs // 2)), "2"], env)
        out[name] = {"runs per minute per core": 60.0 * runs / cpu, "first finished run, 2 workers (s)":
                     parallel["first"], "first finished run, 1 worker (s)": sequential["first"]}
        print(f"monte carlo {name}: {out[name]}", flush=True)
    return out


def first_run_and_fallback(work: Path, repeats: int) -> dict:
    """The paper's NLP with an empty compile cache (compiling included), and without compiling at all."""
    out = {}
    for label, extra in (("empty compile cache", None), ("no compiler (CASADI_SINS_NO_COMPILE=1)",
                                                         {"CASADI_SINS_NO_COMPILE": "1"})):
        cpu, wall = [], []
        for _ in range(max(1, repeats // 2)):
            env = environment(TREE, work, **(extra or {}))
            if extra is None:
                empty = Path(tempfile.mkdtemp(dir=work))
                env["CASADI_SINS_CACHE"] = str(empty)
            recording, args = CASES["paper NLP"]
            c, w, err = timed(calibrate_command(work, recording, args, work / "fallback.csv"), env)
            cpu.append(c)
            wall.append(w)
        out[label] = {"cpu": statistics.median(cpu), "wall": statistics.median(wall)}
        print(f"paper NLP, {label}: CPU {out[label]['cpu']:.2f} s, wall {out[label]['wall']:.2f} s", flush=True)
    return out


def routes(trees: dict, work: Path) -> dict:
    """The NLP's pieces on the paper's recording (in-process CPU): graph build, one Jacobian, one residual
    evaluation, one whitening of residuals and Jacobian; per tree, and the current one on the VM."""
    out = {}
    variants = dict(trees) | {"current, no compiler": TREE}
    for name, tree in variants.items():
        extra = {"CASADI_SINS_NO_COMPILE": "1"} if "no compiler" in name else {}
        out[name], _ = child_json(ROUTES, [str(work / CASES["paper NLP"][0])], environment(tree, work, **extra))
        print(f"routes {name}: " + ", ".join(f"{k} {v:.3g}" for k, v in out[name].items()), flush=True)
    return out


def phases(work: Path) -> dict:
    """One in-process calibration of the paper's recording (a fresh process): CPU by step, the NLP's phases."""
    result, _ = child_json(PHASES, [str(work / CASES["paper NLP"][0])], environment(TREE, work))
    print("in-process phases (CPU s): " + ", ".join(f"{k} {v:.3f}" for k, v in result.items() if k != "nlp phases (wall)")
          + "; NLP phases (wall s): " + ", ".join(f"{k} {v:.3f}" for k, v in result["nlp phases (wall)"].items()))
    return result


def report(times: dict, differences: dict, in_process: dict, mc: dict, first: dict, pieces: dict, load: tuple,
           out: Path, baseline: str = "") -> None:
    """``speed.csv`` (every measured number) and ``speed.md`` (against the targets)."""
    rows = [("whole process", case, tree, measure, value) for case, per_tree in times.items()
            for tree, v in per_tree.items() for measure, value in (("median CPU s", statistics.median(v["cpu"])),
                                                                     ("min CPU s", min(v["cpu"])),
                                                                     ("max CPU s", max(v["cpu"])),
                                                                     ("median wall s", statistics.median(v["wall"])))]
    rows += [("in-process", "paper", "current", k, v) for k, v in in_process.items() if k != "nlp phases (wall)"]
    rows += [("in-process NLP phase (wall)", "paper", "current", k, v) for k, v in in_process["nlp phases (wall)"].items()]
    rows += [("monte carlo", "kang2013", tree, k, v) for tree, d in mc.items() for k, v in d.items()]
    rows += [("routes", "paper", tree, k, v) for tree, d in pieces.items() for k, v in d.items()]
    rows += [("first run", "paper NLP", "current", f"{k} {m} s", v) for k, d in first.items() for m, v in d.items()]
    rows += [("result difference", case, "baseline vs current", m, v) for case, d in differences.items()
             for m, v in zip(("max |dvalue|/sigma", "max |dsigma|/sigma"), d)]
    out.mkdir(parents=True, exist_ok=True)
    (out / "speed.csv").write_text("section,case,tree,measure,value\n" + "".join(
        f"{a},\"{b}\",{c},{d},{e:.6g}\n" for a, b, c, d, e in rows))
    cur = {case: statistics.median(v["current"]["cpu"]) for case, v in times.items()}
    paper = cur["paper NLP"]
    lines = ["# Speed (issue 18)", "", f"Fresh `python -m casadi_sins calibrate` processes, one core, CPU time, median of "
             f"{len(times['paper NLP']['current']['cpu'])} runs; load average {load[0]:.2f} before, {load[1]:.2f} after"
             f" (2 cores shared with other work){f'; baseline: {baseline}, run by run alternating' if baseline else ''}.",
             "", "| case | CPU s | target | ratio to paper NLP | target | met | " + " | ".join(
                 f"{t} CPU s" for t in times["paper NLP"] if t != "current") + " |", "|---|---|---|---|---|---|"
             + "---|" * (len(times["paper NLP"]) - 1)]
    for case, value in cur.items():
        base = [f"{statistics.median(v['cpu']):.3f}" for t, v in times[case].items() if t != "current"]
        met = (value <= TARGETS.get(case, float("inf"))) and (value / paper <= RATIO_TARGETS.get(case, float("inf")))
        lines.append(f"| {case} | {value:.3f} | {TARGETS.get(case, '')} | {value / paper:.2f} | "
                     f"{RATIO_TARGETS.get(case, '')} | {'yes' if met else 'no'} | " + " | ".join(base) + (" |" if base else ""))
    lines += ["", "In-process (CPU s): " + ", ".join(f"{k} {v:.3f}" for k, v in in_process.items()
                                                     if k != "nlp phases (wall)"),
              "NLP phases (wall s): " + ", ".join(f"{k} {v:.3f}" for k, v in in_process["nlp phases (wall)"].items()),
              "", "Monte Carlo (both solvers per run): " + "; ".join(
                  f"{t}: " + ", ".join(f"{k} {v:.3g}" for k, v in d.items()) for t, d in mc.items()),
              "", "The NLP's pieces on the paper's recording (CPU): " + "; ".join(
                  f"{t}: " + ", ".join(f"{k} {v:.3g}" for k, v in d.items()) for t, d in pieces.items()),
              "", "Paper NLP: " + "; ".join(f"{k}: CPU {d['cpu']:.2f} s, wall {d['wall']:.2f} s" for k, d in first.items())]
    if differences:
        lines += ["", "| result difference (baseline vs current) | max abs(dvalue)/sigma | max abs(dsigma)/sigma |",
                  "|---|---|---|"] + [f"| {c} | {a:.2g} | {b:.2g} |" for c, (a, b) in differences.items()]
    (out / "speed.md").write_text("\n".join(lines) + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--baseline", type=Path, help="another checkout (e.g. of main) to alternate with")
    parser.add_argument("--baseline-label", default=None, help="what the baseline is, for the report (default: its folder)")
    parser.add_argument("--work", type=Path, help="recordings and caches (default: a temporary folder)")
    parser.add_argument("--mc-runs", type=int, default=6)
    parser.add_argument("--out", type=Path, default=TREE / "results")
    args = parser.parse_args()
    work = (args.work or Path(tempfile.mkdtemp(prefix="bench-speed-"))).resolve()
    work.mkdir(parents=True, exist_ok=True)
    simulate_recordings(work)
    trees = {"current": TREE} | ({"baseline": args.baseline.resolve()} if args.baseline else {})
    load_before = os.getloadavg()[0]
    times = whole_processes(trees, work, args.repeats, CASES)
    differences = {}
    if args.baseline:
        whole_processes(trees, work, 0, CHECKED)
        differences = table_differences(work, {"baseline": trees["baseline"], "current": TREE})
        for case, (dv, ds) in differences.items():
            print(f"{case}: max |dvalue|/sigma {dv:.2g}, max |dsigma|/sigma {ds:.2g}")
    in_process = phases(work)
    mc = monte_carlo(trees, work, args.mc_runs)
    first = first_run_and_fallback(work, args.repeats)
    pieces = routes(trees, work)
    label = args.baseline_label or (str(args.baseline) if args.baseline else "")
    report(times, differences, in_process, mc, first, pieces, (load_before, os.getloadavg()[0]), args.out, label)
    print(f"wrote {args.out}/speed.csv and speed.md")


if __name__ == "__main__":
    main()
