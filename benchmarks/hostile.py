"""Hostile cases of the mutation benchmark (issue 24): each a way to lose or endanger a user's data.

Every case runs the command line in this process (a 60 s alarm) and is judged:

* traceback: an exception escaping, a message that is not one line, an internal error, exit not 0/2;
* silent_wrong: accepted although it must be refused, or an output with unsafe text (a spreadsheet
  formula in a name cell, a C comment closed early, a live Markdown link);
* partial: an input changed, a device or link replaced, or any output written by a refused command;
* hang: the alarm.
"""

from __future__ import annotations

import bz2
import contextlib
import gzip
import hashlib
import io
import lzma
import os
import random
import re
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd

from casadi_sins.cli import main
from casadi_sins.data.description import read_recording
from casadi_sins.report.cheader import c_header
from casadi_sins.studies.batch import SPREAD_COLUMNS, batch_files

CLASSES = ("huge column", "compression bomb", "device or link output", "formula name", "output onto input",
           "degenerate table")
PULSES = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
ROUGH_TABLE = None  # the rough table of the base recording, made once


class Hang(Exception):
    pass


def _outcome() -> dict:
    return {"traceback": 0, "silent_wrong": 0, "hang": 0, "partial": 0, "accepted": 0, "refused": 0}


def bounded_main(args, outcome: dict, seconds: int = 60) -> tuple[int | None, str]:
    """Run the command line for at most ``seconds``: its status and standard error (None: it hung or raised,
    counted in ``outcome``)."""
    err = io.StringIO()
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(seconds)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = main([str(a) for a in args])
    except Hang:
        outcome["hang"] = 1
        return None, ""
    except BaseException:  # noqa: BLE001
        outcome["traceback"] = 1
        return None, ""
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return status, err.getvalue().strip()


def cli(args: list[str], outcome: dict, must_refuse: bool = True) -> int | None:
    """Run the command line; count its outcome; its status (None: it hung or raised)."""
    status, text = bounded_main(args, outcome)
    if status is None:
        return None
    if status == 0:
        outcome["accepted"] = 1
        outcome["silent_wrong"] |= int(must_refuse)
    else:
        outcome["refused"] = 1
        if status != 2 or len(text.splitlines()) != 1 or "internal error" in text or "Traceback" in text:
            outcome["traceback"] = 1
    return status


def _alarm(signum, frame):
    raise Hang


def _digests(folder: Path) -> dict:
    return {p: (hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() and not p.is_symlink() else
                os.readlink(p) if p.is_symlink() else "special") for p in folder.iterdir()}


def _setup(folder: Path, toml: str, csv: str) -> tuple[Path, Path]:
    (folder / "r.toml").write_text(toml)
    (folder / "r.csv").write_text(csv)
    table = folder / "p.csv"
    table.write_text(_rough_table(folder / "r.toml"))
    return folder / "r.toml", table


def _rough_table(rec: Path) -> str:
    global ROUGH_TABLE
    if ROUGH_TABLE is None:
        from casadi_sins.calibrate.initial import rough_parameters
        from casadi_sins.data.tables import table_text

        ROUGH_TABLE = table_text(rough_parameters(read_recording(rec)))
    return ROUGH_TABLE


def huge_column(folder, toml, csv, rng, outcome):
    frame = pd.read_csv(io.StringIO(csv))
    column = rng.choice(PULSES)
    scale = 10.0 ** rng.uniform(160, 300)
    frame[column] = frame[column] * scale + scale
    (folder / "r.toml").write_text(toml)
    frame.to_csv(folder / "r.csv", index=False)
    command = rng.choice(["validate", "rough", "calibrate"])
    out = [] if command == "validate" else ["--out", str(folder / "out.csv")]
    cli([command, str(folder / "r.toml"), *out], outcome)
    outcome["partial"] |= int((folder / "out.csv").exists())


def compression_bomb(folder, toml, csv, rng, outcome):
    lines = csv.splitlines()
    suffix, opener = rng.choice([(".gz", gzip.open), (".bz2", bz2.open), (".xz", lzma.open)])
    data = folder / f"r.csv{suffix}"
    with opener(data, "wb") as handle:
        handle.write(f"{lines[0]}\n{lines[1]}\n".encode())
        kind = rng.randrange(3)
        unit = (f"{lines[1]}\n".encode() if kind == 0 else b"0" if kind == 1 else b"1,2,3,4,5,6,7\n")
        block = unit * ((1 << 20) // len(unit))
        for _ in range(rng.randrange(2, 10)):  # 2-10 MB of text from a few kB
            handle.write(block)
    (folder / "r.toml").write_text(toml.replace('data = "r.csv"', f'data = "r.csv{suffix}"'))
    cli(["validate", str(folder / "r.toml")], outcome)


def device_output(folder, toml, csv, rng, outcome):
    _, table = _setup(folder, toml, csv)
    kind = rng.randrange(3)
    out = folder / "out.json"
    if kind == 0:
        out.symlink_to(os.devnull)
    elif kind == 1:
        os.mkfifo(out)
    else:
        os.mkfifo(folder / "fifo")
        out.symlink_to(folder / "fifo")
    before = _digests(folder)
    cli(["export", str(table), "--format", rng.choice(["json", "c", "psins", "yaml"]), "--out", str(out)], outcome)
    outcome["partial"] |= int(_digests(folder) != before)


FORMULAS = ("=cmd|' /C calc'!A0", "+1+1", "-2+3", "@SUM(A1:A9)", "=HYPERLINK(\"http://x\")", "\t=1",
            "x */ int evil; /*", "[click](javascript:alert(1))", "![i](http://tracker/x.png)")


def formula_name(folder, toml, csv, rng, outcome):
    name = rng.choice(FORMULAS) + str(rng.randrange(1000))
    toml = re.sub(r'(?m)^name = ".*"$', 'name = "' + name.replace("\\", "\\\\").replace('"', '\\"')
                  .replace("\t", "\\t") + '"', toml, count=1)
    (folder / "r.toml").write_text(toml)
    (folder / "r.csv").write_text(csv)
    if cli(["validate", str(folder / "r.toml")], outcome, must_refuse=False) != 0:
        return
    rec = read_recording(folder / "r.toml")
    fleet = pd.DataFrame({"unit_id": [rec.name], "recording": [name], "status": ["ok"], "warnings": [0],
                          "message": [name]})
    spread = pd.DataFrame([{c: float("nan") for c in SPREAD_COLUMNS}])  # a spread table as batch writes it
    spread[["parameter", "unit", "outliers"]] = ["accel_bias_x", "ug", rec.name]
    files = batch_files(fleet, spread, folder)
    for path, data in files.items():
        if path.suffix == ".csv":
            cells = pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False).to_numpy().ravel()
            outcome["silent_wrong"] |= int(any(str(c).startswith(("=", "+", "@", "-", "\t")) for c in cells))
        elif re.search(rb"(?<!\\)\]\(", data):
            outcome["silent_wrong"] = 1
    from casadi_sins.data.tables import read_table

    header = c_header(read_table(_setup(folder, toml, csv)[1]), {"unit_id": rec.name})
    outcome["silent_wrong"] |= int(header.count("/*") != header.count("*/"))


def output_onto_input(folder, toml, csv, rng, outcome):
    rec, table = _setup(folder, toml, csv)
    data = folder / "r.csv"
    kind = rng.randrange(7)
    if kind in (1, 4):
        os.link(data if kind == 1 else table, folder / "other.csv")
    if kind == 5:
        (folder / "alias.toml").symlink_to(rec)
    args = {0: ["calibrate", str(rec), "--out", str(data)],
            1: ["calibrate", str(rec), "--out", str(folder / "other.csv")],
            2: ["rough", str(rec), "--out", str(rec)],
            3: ["export", str(table), "--format", rng.choice(["json", "c", "psins"]), "--out", str(table)],
            4: ["export", str(table), "--format", "json", "--out", str(folder / "other.csv")],
            5: ["rough", str(rec), "--out", str(folder / "alias.toml")],
            6: ["segment", str(data), "--rate", "100", "--latitude", "37.5", "--out", str(data)]}[kind]
    before = _digests(folder)
    cli(args, outcome)
    outcome["partial"] |= int(_digests(folder) != before)


def degenerate_table(folder, toml, csv, rng, outcome):
    rec, table = _setup(folder, toml, csv)
    lines = table.read_text().splitlines()
    kind = rng.randrange(5)

    def set_value(name, value):
        for k, line in enumerate(lines):
            cells = line.split(",")
            if cells[0] == name:
                cells[2] = value
                lines[k] = ",".join(cells)

    if kind == 0:  # singular: two rows of K alike
        a, b = rng.choice([("gyro_misalign_xy", "gyro_misalign_yx"), ("gyro_misalign_xz", "gyro_misalign_zx"),
                           ("gyro_misalign_yz", "gyro_misalign_zy")])
        set_value(a, "1.0")
        set_value(b, "1.0")
    elif kind == 1:
        set_value(rng.choice(["gyro_scale_x", "accel_scale_y", "gyro_scale_z"]), rng.choice(["0", "0.0", "-0"]))
    elif kind == 2:
        set_value(rng.choice(["accel_bias_x", "gyro_bias_y", "accel_scale_z"]), f"{rng.uniform(1, 9):.3f}e300")
    elif kind == 3:
        set_value(rng.choice(["accel_misalign_yx", "gyro_misalign_zy"]), f"{rng.uniform(1e3, 1e9):.6g}")
    else:
        set_value("gyro_misalign_xy", "0.999999")
        set_value("gyro_misalign_yx", "1.000001")
    table.write_text("\n".join(lines) + "\n")
    before = _digests(folder)
    if rng.random() < 0.3:
        cli(["apply", str(table), str(rec), "--out", str(folder / "applied")], outcome)
    else:
        fmt = rng.choice(["json", "c", "psins", "yaml"])
        cli(["export", str(table), "--format", fmt, "--out", str(folder / f"x.{fmt}")], outcome)
    outcome["partial"] |= int(_digests(folder) != before)


RUNNERS = dict(zip(CLASSES, (huge_column, compression_bomb, device_output, formula_name, output_onto_input,
                             degenerate_table)))


def run(kind: str, folder: Path, toml: str, csv: str, seed: int) -> dict:
    """One hostile case of ``kind`` with ``seed``: its outcome counts."""
    outcome = _outcome()
    RUNNERS[kind](folder, toml, csv, random.Random(seed), outcome)
    return outcome


def big_bomb(folder: Path, toml: str, csv: str, gigabytes: float) -> dict:
    """A gzip file of ``gigabytes`` of rows (one instant repeated) validated by a child process: refused in
    one line, exit 2, within 60 s; its peak memory (``peak_rss_mb``)."""
    folder.mkdir()
    lines = csv.splitlines()
    row = f"{lines[1]}\n".encode()
    block = row * ((8 << 20) // len(row))
    with gzip.open(folder / "r.csv.gz", "wb", compresslevel=1) as handle:
        handle.write(f"{lines[0]}\n{lines[1]}\n".encode())
        for _ in range(int(gigabytes * 1e9 / len(block)) + 1):
            handle.write(block)
    (folder / "r.toml").write_text(toml.replace('data = "r.csv"', 'data = "r.csv.gz"'))
    outcome = _outcome()
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    try:
        done = subprocess.run([sys.executable, "-m", "casadi_sins", "validate", str(folder / "r.toml")],
                              capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        outcome["hang"] = 1
        return {**outcome, "peak_rss_mb": float("nan")}
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    text = done.stderr.strip()
    outcome["refused" if done.returncode else "accepted"] = 1
    outcome["silent_wrong"] = int(done.returncode == 0)
    outcome["traceback"] = int(done.returncode not in (0, 2) or len(text.splitlines()) != 1)
    return {**outcome, "peak_rss_mb": max(peak, before) / 1024.0}
