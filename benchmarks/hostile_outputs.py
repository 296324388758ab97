"""Hostile cases of the mutation benchmark, issue 35: inputs found in folders, outputs a run owns, other tools'
files, declared sizes, near-coincident temperatures, signals around workers.

Each case runs the command line (in this process with a 60 s alarm, or in a child process where memory or
signals are measured) and is judged as the cases of :mod:`hostile`:

* traceback: an exception escaping, a failure that is not one line, an internal error, an exit status other
  than 0, 2, 3, 130, 143;
* silent_wrong: accepted although it must be refused; an imported recording that does not read back as its
  source; a certificate that contradicts the verdict beside it; a thermal model from setpoints too close;
* partial: an input changed or removed (SHA-256 before and after), a file written by a refused command, a
  temporary file left, a process left behind;
* hang: the alarm.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import io
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


CLASSES = ("folder-expansion outputs", "cleanup over inputs", "import edge files", "near-coincident temperatures")
#: Classes run in a child process each (memory or signals measured): their own, smaller, seed count.
CHILD_CLASSES = ("declared-size bombs", "worker signals")
KEYS = ("time", "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
ALLOWED = (0, 2, 3, 130, 143)


_spec = importlib.util.spec_from_file_location("hostile", Path(__file__).resolve().parent / "hostile.py")
hostile = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hostile)
_outcome = hostile._outcome


def cli(args, outcome: dict, expect: tuple = (2,), lines: int | None = 1) -> int | None:
    """Run the command line; count its outcome against the statuses ``expect``; its status."""
    status, text = hostile.bounded_main(args, outcome)
    if status is None:
        return None
    outcome["accepted" if status in (0, 3) else "refused"] = 1
    if status not in ALLOWED or "internal error" in text or "Traceback" in text:
        outcome["traceback"] = 1
    if status == 2 and lines is not None and len(text.splitlines()) != lines:
        outcome["traceback"] = 1
    if status not in expect:
        outcome["silent_wrong"] = 1
    return status


def digests(folder: Path) -> dict:
    """SHA-256 (or the link target) of every file under ``folder``."""
    out = {}
    for path in sorted(folder.rglob("*")):
        if path.is_symlink():
            out[path] = "-> " + os.readlink(path)
        elif path.is_file():
            out[path] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def kept(before: dict, outcome: dict) -> None:
    """``partial`` when an input of ``before`` changed or is gone."""
    for path, digest in before.items():
        now = ("-> " + os.readlink(path)) if path.is_symlink() else (
            hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None)
        if now != digest:
            outcome["partial"] = 1


def _recording(folder: Path, toml: str, csv: str, name: str = "u1", data: str | None = None) -> list[Path]:
    """A recording ``name.toml`` with its samples in ``data`` (default ``name.csv``) in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    data = data or f"{name}.csv"
    text = toml.replace('data = "r.csv"', f'data = "{data}"')
    text = "\n".join(f'name = "{name}"' if line.startswith("name = ") else line for line in text.splitlines())
    (folder / f"{name}.toml").write_text(text + "\n")
    (folder / data).write_text(csv)
    return [folder / f"{name}.toml", folder / data]


# ----- folder-expansion outputs ---------------------------------------------------------------------------------

def folder_expansion(folder, toml, csv, rng, outcome):
    """batch over folders whose recordings collide with the outputs it lays out (refused before any unit), or a
    safe layout (calibrated, nothing of the inputs touched)."""
    kind = rng.choices(range(5), weights=[3, 3, 2, 2, 1])[0]
    if kind == 0:  # recordings kept in X/units, batch X/units --out X
        inputs = _recording(folder / "X" / "units", toml, csv, "u1")
        args, expect = ["batch", folder / "X" / "units", "--out", folder / "X"], (2,)
    elif kind == 1:  # a data file named as a fleet file, batch DIR --out DIR
        inputs = _recording(folder / "D", toml, csv, "a", data=rng.choice(["fleet.csv", "fleet.md", "fleet-spread.csv",
                                                                           "fleet-spread.md"]))
        args, expect = ["batch", folder / "D", "--out", folder / "D"], (2,)
    elif kind == 2:  # one unit's data is another unit's table
        inputs = _recording(folder / "X" / "units", toml, csv, "a", data="b.csv")
        inputs += _recording(folder / "X" / "units", toml, csv, "b", data="b-samples.csv")
        args, expect = ["batch", folder / "X" / "units", "--out", folder / "X"], (2,)
    elif kind == 3:  # a recording named explicitly inside OUT/units
        inputs = _recording(folder / "OUT" / "units", toml, csv, rng.choice(["u1", "SN-7"]))
        args, expect = ["batch", inputs[0], "--out", folder / "OUT"], (2,)
    else:  # safe: the outputs beside, not over, the recordings
        inputs = _recording(folder / "D", toml, csv, "u1")
        args, expect = ["batch", folder / "D", "--out", folder / "D" / "out"], (0,)
    before = digests(folder)
    status = cli([*args, "--workers", "1", "--quiet", "--no-progress"], outcome, expect)
    kept({p: before[p] for p in inputs}, outcome)
    if status == 2 and digests(folder) != before:
        outcome["partial"] = 1


# ----- cleanup over inputs --------------------------------------------------------------------------------------

OWNED = ("report.json", "report.md", "certificate.html", "certificate.pdf", "compensation.json", "compensation.yaml",
         "clbt.m", "compensation.h")


def cleanup_over_inputs(folder, toml, csv, rng, outcome):
    """Inputs named, linked or laid out as files a run owns and would replace or remove: never touched."""
    rec, data = _recording(folder, toml, csv, "r")
    kind = rng.choices(range(5), weights=[3, 3, 2, 2, 1])[0]
    if kind == 0:  # an input named as a file of the table's stem
        owned = folder / f"P.{rng.choice(OWNED)}"
        option = rng.choice(["--noise", "--tolerance"])
        owned.write_text("gyro_arw_deg_rth = 0.002\n" if option == "--noise" else
                         'format = "casadi-sins-tolerance/1"\n[accept.sigma]\ngyro_bias_x = 1.0\n')
        args, expect = ["calibrate", rec, "--out", folder / "P.csv", option, owned], (2,)
    elif kind == 1:  # a file of the stem is a link to an input
        owned = folder / f"P.{rng.choice(OWNED)}"
        if rng.random() < 0.5:
            os.link(data, owned)
        else:
            owned.symlink_to(rng.choice([rec, data]))
        args, expect = ["calibrate", rec, "--out", folder / "P.csv"], (2,)
    elif kind == 2:  # a failed unit inside OUT/units with its earlier outputs: those go, its samples stay
        units = folder / "OUT" / "units"
        rec, data = _recording(units, toml, "\n".join(csv.splitlines()[:rng.randrange(3, 60)]) + "\n", "u1",
                               data="u1-samples.csv")
        for name in ("csv", *rng.sample(OWNED, 3)):
            (units / f"u1.{name}").write_text("an earlier run")
        args, expect = ["batch", rec, "--out", folder / "OUT", "--workers", "1", "--quiet"], (2,)
    elif kind == 3:  # a unit's owned file hard-linked to its samples
        units = folder / "OUT" / "units"
        units.mkdir(parents=True)
        os.link(data, units / f"r.{rng.choice(OWNED)}")
        args, expect = ["batch", rec, "--out", folder / "OUT", "--workers", "1", "--quiet"], (2,)
    else:  # a failing rerun: no certificate of the earlier pass may stay
        _rerun(folder, rec, data, outcome)
        return
    before = digests(folder)
    stale = {p for p in before if kind == 2 and p.name.startswith("u1.") and p.name != "u1.toml"}
    status = cli(args, outcome, expect, lines=0 if kind == 2 else 1)
    kept({p: d for p, d in before.items() if p not in stale}, outcome)  # every input, each link included
    if kind == 2:
        left = sorted(p.name for p in (folder / "OUT" / "units").iterdir())
        if left != ["u1-samples.csv", "u1.toml"]:
            outcome["partial"] = 1  # a stale output of the failed unit left, or an input gone
    elif status == 2 and digests(folder) != before:
        outcome["partial"] = 1


def _rerun(folder, rec, data, outcome):
    loose, tight = folder / "loose.toml", folder / "tight.toml"
    loose.write_text('format = "casadi-sins-tolerance/1"\n[accept.sigma]\ngyro_bias_x = 1.0\n')
    tight.write_text('format = "casadi-sins-tolerance/1"\n[accept.sigma]\ngyro_bias_x = 1e-12\n')
    before = digests(folder)
    table = folder / "SN.csv"
    cli(["calibrate", rec, "--out", table, "--tolerance", loose, "--certificate"], outcome, (0,))
    cli(["calibrate", rec, "--out", table, "--tolerance", tight], outcome, (3,))
    kept(before, outcome)
    certificate = folder / "SN.certificate.html"
    report = json.loads((folder / "SN.report.json").read_text()) if (folder / "SN.report.json").exists() else {}
    if certificate.exists() and report.get("verdict") == "fail":
        outcome["silent_wrong"] = 1


# ----- import edge files ----------------------------------------------------------------------------------------

SAMPLES = None


def _samples(csv: str) -> np.ndarray:
    global SAMPLES
    if SAMPLES is None:
        SAMPLES = np.loadtxt(io.StringIO(csv), delimiter=",", skiprows=1)
    return SAMPLES.copy()


#: Mutations of the arrays: ``(name, must refuse)``.
ARRAY_EDITS = (("none", False), ("nan", True), ("inf", True), ("huge pulse", True), ("huge temperature", True),
               ("nan temperature", True), ("short temperature", True), ("time repeats", True),
               ("time backwards", True), ("float32", False), ("int pulses", False), ("transposed", False),
               ("three-d", True), ("empty", True), ("one row", True))
#: Mutations of the file itself (after writing it).
FILE_EDITS = ("none", "truncate", "zero", "junk")
#: Hostile options: ``(arguments, must refuse)``.
OPTIONS = ((["--name", "a\nb"], True), (["--name", "x" * 10_000], True), (["--height", "1e9"], True),
           (["--height", "nan"], True), (["--rate", "nan"], True), (["--rate", "0"], True), ([], False),
           (["--name", "=cmd|' /C calc'!A0"], False), (["--latitude", "91"], True))


def _arrays(data: np.ndarray, edit: str, rng) -> tuple[dict, bool]:
    """Named arrays of the samples after ``edit`` (``time``, ``gyro``, ``accel``, maybe ``temperature``)."""
    time_, gyro, accel = data[:, 0], data[:, 1:4], data[:, 4:7]
    temperature = np.full(len(time_), 23.0) if rng.random() < 0.5 else None
    row = rng.randrange(len(time_))
    if edit == "nan":
        (gyro if rng.random() < 0.5 else time_.reshape(-1, 1))[row, 0] = np.nan
    elif edit == "inf":
        accel[row, rng.randrange(3)] = np.inf
    elif edit == "huge pulse":
        gyro[row, rng.randrange(3)] = 10.0 ** rng.uniform(17, 308)
    elif edit in ("huge temperature", "nan temperature"):
        temperature = np.full(len(time_), 23.0)
        temperature[row] = 1e308 if edit == "huge temperature" else np.nan
    elif edit == "short temperature":
        temperature = np.full(rng.randrange(1, 20), 23.0)
    elif edit == "time repeats":
        time_[row] = time_[row - 1] if row else time_[1]
    elif edit == "time backwards":
        time_ = time_[::-1].copy()
    elif edit == "float32":
        gyro, accel = gyro.astype(np.float32), accel.astype(np.float32)
    elif edit == "int pulses":
        gyro, accel = np.round(gyro).astype(np.int64), np.round(accel).astype(np.int64)
    elif edit == "three-d":
        gyro = np.stack([gyro, gyro], axis=-1)
    elif edit == "empty":
        time_, gyro, accel = time_[:0], gyro[:0], accel[:0]
        temperature = None
    elif edit == "one row":
        time_, gyro, accel = time_[:1], gyro[:1], accel[:1]
        temperature = None
    arrays = {"time": time_, "gyro": gyro, "accel": accel}
    if temperature is not None:
        arrays["temperature"] = temperature
    return arrays, edit == "transposed"


def _write_foreign(kind: str, path: Path, arrays: dict, transposed: bool) -> list[str]:
    """The arrays in another tool's file; the ``--map`` options naming them."""
    if kind == "mat":
        import scipy.io

        scipy.io.savemat(path, {k: (v.T if transposed and v.ndim == 2 else v) for k, v in arrays.items()},
                         do_compression=True)
        return []
    if kind == "hdf5":
        import h5py

        with h5py.File(path, "w") as handle:
            for key, value in arrays.items():
                handle[f"imu/{key}"] = value.T if transposed and value.ndim == 2 else value
        return ["--map", *(f"{k}=imu/{k}" for k in arrays)]
    if kind == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        columns = {"time": arrays["time"]}
        for sensor in ("gyro", "accel"):
            value = arrays[sensor]
            if value.ndim != 2:
                columns[f"{sensor}_x"] = np.asarray(value).reshape(len(value), -1)[:, 0].astype(str)
                continue
            for j, axis in enumerate("xyz"):
                columns[f"{sensor}_{axis}"] = value[:, j]
        if "temperature" in arrays and len(arrays["temperature"]) == len(arrays["time"]):
            columns["temperature"] = arrays["temperature"]
        elif "temperature" in arrays:  # a table cannot hold columns of two lengths: a text column instead
            columns["temperature"] = np.array(["23"] * len(arrays["time"]))
        pq.write_table(pa.table(columns), path)
        return []
    table = np.column_stack([arrays["gyro"], arrays["accel"], arrays["time"]]) if arrays["gyro"].ndim == 2 and \
        len(arrays["gyro"]) == len(arrays["time"]) else np.zeros((3, 5))
    np.savetxt(path, table, fmt="%.17g")
    return []


def import_edge_files(folder, toml, csv, rng, outcome):
    """A file of another tool with one hostile edit, or hostile options: read back as written, or one line."""
    kind = rng.choice(["mat", "hdf5", "parquet", "psins"])
    edit, edit_refuses = rng.choice(ARRAY_EDITS)
    file_edit = rng.choices(FILE_EDITS, weights=[10, 1, 1, 1])[0]
    options, option_refuses = rng.choices(OPTIONS, weights=[1, 1, 1, 1, 1, 1, 6, 1, 1])[0]
    arrays, transposed = _arrays(_samples(csv), edit, rng)
    if kind == "psins" and edit in ("short temperature", "huge temperature", "nan temperature"):
        edit_refuses = False  # the [wm vm t] array has no temperature
    if kind == "psins" and edit == "transposed":
        edit_refuses = False
    (folder / "orig.toml").write_text(toml)
    (folder / "r.csv").write_text(csv)
    src = folder / {"mat": "imu.mat", "hdf5": "imu.h5", "parquet": "imu.parquet", "psins": "imu.txt"}[kind]
    try:
        maps = _write_foreign(kind, src, arrays, transposed)
    except Exception:  # noqa: BLE001 (a library refusing to write the edit: a junk file instead)
        maps, file_edit = [], "junk"
    if file_edit == "truncate":
        src.write_bytes(src.read_bytes()[: rng.randrange(1, max(2, src.stat().st_size))])
    elif file_edit == "zero":
        src.write_bytes(b"")
    elif file_edit == "junk":
        src.write_bytes(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 4096))))
    out = folder / "out" / ("rec.toml" if rng.random() < 0.9 else "rec.csv")
    refuses = edit_refuses or option_refuses or file_edit != "none" or out.suffix == ".csv"
    schedule = ["--segments", folder / "orig.toml"] if "--latitude" not in options else []
    before = digests(folder)
    status = cli(["import", kind, src, *schedule, *maps, *options, "--out", out], outcome, (2,) if refuses else (0, 2))
    kept(before, outcome)
    if status == 2 and (folder / "out").exists() and any((folder / "out").iterdir()):
        outcome["partial"] = 1
    if status == 0:
        _read_back(out, arrays, outcome)


def _read_back(out: Path, arrays: dict, outcome: dict) -> None:
    """``silent_wrong`` unless the written recording reads back with the source's pulses."""
    from casadi_sins.data.description import read_recording

    try:
        back = read_recording(out)
    except Exception:  # noqa: BLE001
        outcome["silent_wrong"] = 1
        return
    gyro, accel = (np.asarray(arrays[k], dtype=float) for k in ("gyro", "accel"))
    gyro, accel = (v if v.shape[0] == len(back.time) else v.T for v in (gyro, accel))
    if not (np.array_equal(back.gyro, gyro) and np.array_equal(back.accel, accel)):
        outcome["silent_wrong"] = 1


# ----- near-coincident temperatures -----------------------------------------------------------------------------

def near_coincident(folder, toml, csv, rng, outcome):
    """Tables at temperatures from 1e-15 to 0.3 degC apart (and sometimes a third far away): a model only from
    setpoints more than 0.1 degC apart."""
    from casadi_sins.data.tables import write_table
    from casadi_sins.model.parameters import ParameterSet
    from casadi_sins.model.registry import NAMES, natural_scale_of, relative_mask

    size = natural_scale_of(NAMES) * np.where(relative_mask(NAMES), 1e-5, 1.0)
    nominal = np.where(relative_mask(NAMES), 1e-5, 0.0)
    gen = np.random.default_rng(rng.randrange(1 << 30))
    t0 = rng.uniform(-40, 80)
    temps = [t0, t0 + 10.0 ** rng.uniform(-15, -0.5)]
    if rng.random() < 0.3:
        temps.append(t0 + rng.uniform(5, 40))
    paths = []
    for k, t in enumerate(temps):
        path = folder / f"T{k}.csv"
        write_table(path, ParameterSet(nominal + size * gen.normal(size=len(NAMES)) * 0.2, sigma=size * 0.2))
        paths.append(f"{path}@{t!r}")
    must_refuse = max(temps) - min(temps) <= 0.1
    before = digests(folder)
    status = cli(["thermal", *paths, "--out", folder / "out", "--no-plots"], outcome, (2,) if must_refuse else (0,))
    kept(before, outcome)
    if status == 0:
        model = json.loads((folder / "out" / "thermal.json").read_text())
        numbers = np.array([v for v in _numbers(model)], dtype=float)
        if not np.all(np.isfinite(numbers)):
            outcome["silent_wrong"] = 1


def _numbers(value):
    if isinstance(value, dict):
        for item in value.values():
            yield from _numbers(item)
    elif isinstance(value, list):
        for item in value:
            yield from _numbers(item)
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield value


# ----- child classes: declared-size bombs, signals around workers -------------------------------------------------

#: The command line in a child that reports its own peak memory (MB) as its last line of standard error: the new
#: process image's ``VmHWM`` (Linux carries the parent's peak into ``ru_maxrss`` across fork and exec).
PEAK = ("import sys\nfrom casadi_sins.cli import main\nstatus = main(sys.argv[1:])\n"
        "print(next(float(l.split()[1]) / 1024 for l in open('/proc/self/status') if l.startswith('VmHWM:')), "
        "file=sys.stderr)\nsys.exit(status)")


def declared_bombs(folder, toml, csv, rng, outcome):
    """A small file declaring many rows (HDF5 fill values, Parquet constant rows, a compressed .mat of zeros):
    refused in one line with a true message, under 1 GB of peak memory."""
    kind = rng.choice(["hdf5", "parquet", "mat"])
    src = _bomb(kind, folder, rng)
    size_mb = src.stat().st_size / 1e6
    before = digests(folder)
    try:
        done = subprocess.run([sys.executable, "-c", PEAK, "import", kind, str(src), "--latitude", "37.5", "--out",
                               str(folder / "out" / "r.toml")], capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        outcome["hang"] = 1
        return {"peak_rss_mb": float("nan")}
    lines = done.stderr.strip().splitlines()
    peak = float(lines[-1]) if lines and lines[-1].replace(".", "", 1).isdigit() else float("nan")
    text = "\n".join(lines[:-1])
    outcome["refused" if done.returncode else "accepted"] = 1
    outcome["silent_wrong"] = int(done.returncode == 0 or "not a Parquet file" in text)
    outcome["traceback"] = int(done.returncode not in (0, 2) or len(text.splitlines()) != 1 or "internal" in text)
    kept(before, outcome)
    outcome["partial"] |= int((folder / "out").exists())
    outcome["partial"] |= int(not peak < 1000.0 and size_mb < 100)  # over the memory bar counts as a failure
    return {"peak_rss_mb": peak}


_BOMB_CACHE: dict = {}


def _bomb(kind: str, folder: Path, rng) -> Path:
    """A bomb file (the large ones made once and linked into each case's folder)."""
    if kind == "hdf5":
        import h5py

        rows = int(10 ** rng.uniform(7, 9.5))
        path = folder / "bomb.h5"
        with h5py.File(path, "w") as handle:
            fill = rng.choice([0.0, 1.0])
            for key in KEYS:
                handle.create_dataset(key, shape=(rows,), dtype="f8", chunks=(1 << 20,), compression="gzip",
                                      fillvalue=fill)
        return path
    rows = rng.choice([1 << 24, 1 << 27]) if kind == "parquet" else rng.choice([1 << 22, 1 << 24])
    key = (kind, rows)
    if key not in _BOMB_CACHE:
        store = folder.parent / "bombs"  # inside the benchmark's temporary folder, removed with it
        store.mkdir(exist_ok=True)
        path = store / (f"constant-{rows}.parquet" if kind == "parquet" else f"zeros-{rows}.mat")
        if kind == "parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            block = pa.table({k: np.ones(1 << 20) for k in KEYS})
            with pq.ParquetWriter(path, block.schema, compression="zstd") as writer:
                for _ in range(rows >> 20):
                    writer.write_table(block)
        else:
            import scipy.io

            zeros = np.zeros(rows)
            scipy.io.savemat(path, {k: zeros for k in KEYS}, do_compression=True)
        _BOMB_CACHE[key] = path
    target = folder / _BOMB_CACHE[key].name
    os.link(_BOMB_CACHE[key], target)
    return target


#: A child running the command line as the console script does (a late signal, after the command, is ignored): it
#: says "ready" once imported (an interruption while the package is still importing is issue 34's), then runs it.
READY = "import sys\nfrom casadi_sins.console import console\nprint('ready', file=sys.stderr, flush=True)\nconsole()"


def worker_signals(folder, toml, csv, rng, outcome):
    """Ctrl-C or SIGTERM at a random moment of a batch on a local Dask cluster or a process pool: 0, 130 or 143,
    one line, no traceback, no process left, no temporary file."""
    recs = _recording(folder / "recs", toml, csv, "a")[:1] + _recording(folder / "recs", toml, csv, "b")[:1]
    dask = rng.random() < 0.6
    sig = rng.choice([signal.SIGINT, signal.SIGTERM])
    args = ["batch", *map(str, recs), "--out", str(folder / "out"), "--workers", "2", "--quiet", "--no-progress"]
    args += ["--dask", "local"] if dask else []
    before = digests(folder)
    child = subprocess.Popen([sys.executable, "-c", READY, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             text=True, start_new_session=True)
    if child.stderr.readline().strip() != "ready":
        outcome["traceback"] = 1
    time.sleep(rng.uniform(0.0, 6.0))  # a batch of two short units takes 5-15 s after the import
    with contextlib.suppress(ProcessLookupError):
        child.send_signal(sig)
    try:
        _, err = child.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        child.kill()
        outcome["hang"] = 1
        return {}
    word = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}[sig]
    status, text = child.returncode, err.strip()
    outcome["refused" if status else "accepted"] = 1
    ok = (status == 0 and text == "") or (status == {signal.SIGINT: 130, signal.SIGTERM: 143}[sig] and text == word)
    outcome["traceback"] |= int(not ok)
    kept(before, outcome)
    left = _running_in_session(child.pid)
    stray = [p for p in (folder / "out").rglob(".*") if p.is_file()] if (folder / "out").exists() else []
    outcome["partial"] |= int(bool(left) or bool(stray) or (status != 0 and (folder / "out" / "fleet.csv").exists()))
    return {}


def _running_in_session(session: int) -> list[str]:
    for _ in range(10):
        listing = subprocess.run(["ps", "-s", str(session), "-o", "pid=,stat="], capture_output=True, text=True).stdout
        left = [line.split()[0] for line in listing.splitlines() if line.split() and not line.split()[1].startswith("Z")]
        if not left:
            return []
        time.sleep(0.5)
    return left


RUNNERS = {"folder-expansion outputs": folder_expansion, "cleanup over inputs": cleanup_over_inputs,
           "import edge files": import_edge_files, "near-coincident temperatures": near_coincident,
           "declared-size bombs": declared_bombs, "worker signals": worker_signals}


def run(kind: str, folder: Path, toml: str, csv: str, seed: int) -> dict:
    """One case of ``kind`` with ``seed``: its outcome counts (and the peak memory of a child, when measured)."""
    outcome = _outcome()
    extra = RUNNERS[kind](folder, toml, csv, random.Random(f"{kind}-{seed}"), outcome) or {}
    return {**outcome, **extra}
