"""Mutation run over the recording reader and the command line (issue 17's bar).

Run: ``python benchmarks/bench_mutations.py [--seeds 150] [--calibrate-every 25] [--out results]``.

Each case mutates a valid recording (the paper's schedule with short segments): one of the CSV
mutations of ``tests/fuzz/mutations.py`` (a comma inserted into a number, a field appended, lines
deleted, duplicated or swapped, characters replaced, columns renamed, reordered or added, values
scaled, blank lines, CRLF) or one of its TOML edits (missing keys, bad spellings, code in the name,
``../`` names, deep nesting, a device as data).  ``casadi-sins validate`` runs on it in this process
with a 20 s alarm.  Counted:

* traceback: an exception escaping the command, or a message that is not one line;
* silent wrong table: a recording accepted whose numbers differ from what a strict independent
  reader (Python's ``csv``) finds in the text, or accepted although that reader finds no valid table;
* hang: the alarm;
* partial output: on every ``--calibrate-every``-th accepted case ``casadi-sins calibrate`` writes a
  table and its report into a fresh folder; afterwards either all of them exist or none.

Issue 24 adds the hostile classes of :mod:`hostile` (beside this file): huge finite columns,
compression bombs (and one of 1 GB of rows in a child process, its peak memory measured), device and
link outputs, formula names, outputs onto inputs, degenerate tables; each through the command line,
refusals expected (one line, exit 2), inputs byte-identical and nothing written.

Issue 35 adds the classes of :mod:`hostile_outputs`: batch over folders whose recordings collide with its
outputs, inputs named or linked as files a run owns and would remove, other tools' files with hostile
edits (``import``), small files declaring many rows (in a child, its peak memory measured), thermal
setpoints too close to fit, and Ctrl-C or SIGTERM at a random moment of a batch on a Dask cluster or a
process pool (in a child: its exit status, one line, no process left).

Writes ``results/mutations.{csv,md}`` (one row per mutation class) and prints the totals.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import signal
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from casadi_sins.cli import main
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.data.problem import load_problem
from casadi_sins.report.tables import write_frame
from casadi_sins.sim import simulate

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("mutations", ROOT / "tests" / "fuzz" / "mutations.py")
mutations = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(mutations)
_spec = importlib.util.spec_from_file_location("hostile", Path(__file__).resolve().parent / "hostile.py")
hostile = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hostile)
_spec = importlib.util.spec_from_file_location("hostile_outputs", Path(__file__).resolve().parent / "hostile_outputs.py")
hostile_outputs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hostile_outputs)


class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang


def run_case(folder: Path, toml: str, csv: str, calibrate: bool) -> dict:
    """One mutated recording through ``validate`` (and ``calibrate``): what happened."""
    (folder / "r.toml").write_text(toml)
    (folder / "r.csv").write_text(csv)
    err = io.StringIO()
    outcome = {"traceback": 0, "silent_wrong": 0, "hang": 0, "partial": 0, "accepted": 0, "refused": 0}
    signal.alarm(20)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = main(["validate", str(folder / "r.toml")])
    except Hang:
        outcome["hang"] = 1
        return outcome
    except BaseException:  # noqa: BLE001 (anything escaping the command is a traceback)
        outcome["traceback"] = 1
        return outcome
    finally:
        signal.alarm(0)
    text = err.getvalue().strip()
    if status != 0:
        outcome["refused"] = 1
        if status != 2 or len(text.splitlines()) != 1 or "internal error" in text:
            outcome["traceback"] = 1
        return outcome
    outcome["accepted"] = 1
    expected = mutations.oracle(csv)
    rec = read_recording(folder / "r.toml")
    got = np.column_stack([rec.time, rec.gyro, rec.accel])
    if expected is None or expected.shape != got.shape or not np.array_equal(expected, got):
        outcome["silent_wrong"] = 1
    if calibrate:
        out = folder / "out"
        with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
            main(["calibrate", str(folder / "r.toml"), "--out", str(out / "p.csv")])
        present = [(out / name).exists() for name in ("p.csv", "p.report.json", "p.report.md")]
        stray = list(out.glob(".*tmp")) if out.exists() else []
        if (any(present) and not all(present)) or stray:
            outcome["partial"] = 1
    return outcome


def main_benchmark():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=150, help="seeds per CSV mutation class (default 150)")
    parser.add_argument("--toml-seeds", type=int, default=25, help="seeds per TOML edit (default 25)")
    parser.add_argument("--calibrate-every", type=int, default=25, help="calibrate every n-th accepted case")
    parser.add_argument("--hostile-seeds", type=int, default=100, help="seeds per hostile class (default 100)")
    parser.add_argument("--outputs-seeds", type=int, default=100, help="seeds per issue-35 class run in this process "
                        "(folder-expansion outputs, cleanup over inputs, import edge files, near-coincident "
                        "temperatures; default 100)")
    parser.add_argument("--child-seeds", type=int, default=20, help="seeds per issue-35 class run in a child process "
                        "(declared-size bombs, worker signals; default 20)")
    parser.add_argument("--bomb-gb", type=float, default=1.0, help="rows of the big gzip bomb, GB (0: none)")
    parser.add_argument("--out", default=str(ROOT / "results"), help="folder of the results tables")
    args = parser.parse_args()
    problem = load_problem()
    problem = problem.__class__(**{**problem.__dict__, "name": "short",
                                   "timing": problem.timing.__class__(static_s=8.0, rotation_s=4.0)})
    signal.signal(signal.SIGALRM, _alarm)
    rows, accepted = [], 0
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        base = write_recording(simulate(problem, seed=6).recording, Path(tmp) / "orig" / "r.toml")
        toml, csv = base.read_text(), base.with_suffix(".csv").read_text()
        cases = [("csv " + kind, seed) for kind in sorted(mutations.CSV_MUTATIONS) for seed in range(args.seeds)]
        cases += [(f"toml edit {i}", seed) for i in range(len(mutations.TOML_EDITS)) for seed in range(args.toml_seeds)]
        cases += [(kind, seed) for kind in hostile.CLASSES for seed in range(args.hostile_seeds)]
        cases += [(kind, seed) for kind in hostile_outputs.CLASSES for seed in range(args.outputs_seeds)]
        cases += [(kind, seed) for kind in hostile_outputs.CHILD_CLASSES for seed in range(args.child_seeds)]
        if args.bomb_gb > 0:
            rows.append({"class": f"gzip bomb {args.bomb_gb:g} GB of rows",
                         **hostile.big_bomb(Path(tmp) / "bomb", toml, csv, args.bomb_gb)})
        for n, (kind, seed) in enumerate(cases):
            folder = Path(tmp) / f"case{n}"
            folder.mkdir()
            if kind in hostile.CLASSES:
                rows.append({"class": kind, **hostile.run(kind, folder, toml, csv, seed)})
                continue
            if kind in hostile_outputs.RUNNERS:
                rows.append({"class": kind, **hostile_outputs.run(kind, folder, toml, csv, seed)})
                continue
            if kind.startswith("csv "):
                case_toml, case_csv = toml, mutations.mutate_csv(csv, kind[4:], seed)
            else:
                case_toml, case_csv = mutations.mutate_toml(toml, int(kind.split()[-1]), seed), csv
            calibrate = accepted % args.calibrate_every == 0
            outcome = run_case(folder, case_toml, case_csv, calibrate)
            accepted += outcome["accepted"]
            rows.append({"class": kind, **outcome})
            if n % 250 == 0:
                print(f"{n}/{len(cases)} cases, {time.perf_counter() - started:.0f} s", flush=True)
    frame = pd.DataFrame(rows)
    table = frame.groupby("class").sum(numeric_only=True).reset_index()
    table.insert(1, "cases", frame.groupby("class").size().to_numpy())
    totals = table.drop(columns="class").sum()
    if "peak_rss_mb" in table:
        table["peak_rss_mb"] = frame.groupby("class")["peak_rss_mb"].max().to_numpy()
    print(table.to_string(index=False))
    print(f"{len(frame)} cases in {time.perf_counter() - started:.0f} s: {totals['traceback']} tracebacks, "
          f"{totals['silent_wrong']} silent wrong tables, {totals['partial']} partial outputs, {totals['hang']} hangs; "
          f"{totals['accepted']} accepted, {totals['refused']} refused")
    write_frame(table, Path(args.out) / "mutations", f"Mutation run: {len(frame)} mutated recordings through "
                f"validate (and calibrate on every {args.calibrate_every}-th accepted one); counts per class")
    return 0 if totals[["traceback", "silent_wrong", "partial", "hang"]].sum() == 0 else 1


if __name__ == "__main__":
    sys.exit(main_benchmark())
