"""A production batch: many units' recordings calibrated, a fleet table, the spread across units.

Every recording is one unit (its unit id is the recording's ``name``).  Each is calibrated on its own
(in local worker processes, or on a Dask cluster: a scheduler address or ``"local"``, through
:func:`studies.parallel.run_all` as the Monte Carlo); its table and report are written under ``OUT/units/`` as soon as it is
done, so that an interrupted batch resumes: a unit whose table and report exist and whose report
names the SHA-256 of the recording as it is now is not calibrated again.  A unit that fails (an
unreadable recording, a calibration that does not converge) is reported in the fleet table with its
one-line reason; it never stops the others.  On a remote cluster the workers must read the
recordings at the same paths (a shared file system); the results come back to this process, which
writes every file.

The fleet table has one row per unit (unit id, status, warnings, every parameter's value and sigma
in SI); the spread table one row per parameter across the units that calibrated: median, robust
spread (1.4826 x the median absolute deviation) and the units beyond ``threshold`` times the larger
of that spread and the median sigma of one unit, flagged as outliers.
"""

from __future__ import annotations

import base64
import dataclasses
import functools
import hashlib
import html
import math
import re
import os
import shlex
import types
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from ..calibrate import CalibrationError, calibrate, prepare_compiled
from ..core.errors import InputError
from ..core.guard import reading_own_outputs
from ..core.files import file_sha256, safe_stem, write_files
from ..core.text import one_line, plural, spreadsheet_cell
from ..core.toml import read_toml
from ..data.datasheet import read_datasheet
from ..data.record import TABLE_SHA256_KEY as LEDGER_TABLE_KEY  # noqa: F401 (the ledger's key, for tests and tools)
from ..data.record import CalibrationRecord, companion_paths, parse_report, read_report, report_path
from ..data.description import read_recording
from ..data.segmentation import refine
from ..data.tables import read_table, table_text
from ..model.registry import ALL_NAMES, natural_scale_of, natural_unit_of, natural_value_of, relative_mask
from ..report.acceptance import judge, read_acceptance_sheet, sheet_sha256
from ..report.calibration import (calibration_outputs, certificate_files, certificate_path, recording_hash,
                                  report_files, report_markdown)
from ..report.rounding import display, sigma_in_value_unit
from ..report.tables import frame_files
from .parallel import run_all

#: Outlier threshold in robust spreads (see the module docstring).
OUTLIER_THRESHOLD = 5.0
#: The columns of the spread table.
SPREAD_COLUMNS = ("parameter", "unit", "units", "median (SI)", "robust spread", "std", "min", "max",
                  "median unit sigma", "outliers")
#: The columns of the fleet tables that carry names (unit ids, paths, messages): no formula in a spreadsheet.
NAME_COLUMNS = ("unit_id", "recording", "message", "outliers")


@dataclasses.dataclass(frozen=True)
class BatchOptions:
    """How each unit is calibrated: solver, model, an optional datasheet (TOML path)."""

    solver: str = "nlp"
    model: str = "21"
    noise: str | None = None
    tolerance: str | None = None  # a tolerance sheet with acceptance limits: each unit's verdict
    certificate: str | None = None  # each unit's certificate: "html" (NAME.certificate.html) or "pdf"


def unit_table_path(out_dir, rec_path) -> Path:
    """``OUT/units/STEM.csv``: the table of the unit of a recording ``STEM.toml``."""
    return Path(out_dir) / "units" / f"{safe_stem(Path(rec_path).stem)}.csv"


def file_hash(rec_path) -> str | None:
    """The recording's SHA-256 as ``calibrate`` records it (TOML and data), from its path alone."""
    return recording_hash(types.SimpleNamespace(source=Path(rec_path)))


def finished(rec_path, out_dir, certificate: str | None = None) -> dict | None:
    """The report of a unit already calibrated from this very recording, or None: the report (the ledger)
    names the recording's SHA-256 as it is now and the SHA-256 of the stored table as it is now (a table
    changed, truncated or replaced since is calibrated again); with ``certificate`` (``"html"``, ``"pdf"``) its
    certificate of that kind exists."""
    table = unit_table_path(out_dir, rec_path)
    if not (table.is_file() and report_path(table).is_file()) or (
            certificate and not certificate_path(table, certificate).is_file()):
        return None
    try:
        with reading_own_outputs():  # the batch's own ledger, rewritten when the unit is calibrated again
            data = read_report(table)
        stored = file_sha256(table)
    except (OSError, InputError):
        return None
    record = CalibrationRecord.of_report(data, table)
    digest = record.recording_sha256
    same_table = record.stored_table_sha256 == stored
    return data if digest and digest == file_hash(rec_path) and same_table else None


def row_from_report(data: dict, rec_path, status: str) -> dict:
    """The fleet-table row of a unit from its report data; its message gives the reasons of a failed verdict
    first, then the warnings (every unit out of tolerance says why)."""
    record = CalibrationRecord.of_report(data)
    warnings, reasons, conditions = record.warnings, record.reasons, record.conditions
    row = {"unit_id": record.unit_id or Path(rec_path).stem, "recording": str(rec_path),
           "status": status if not warnings or status != "ok" else "warnings", "warnings": len(warnings),
           "message": " | ".join([*(f"out of tolerance: {r}" for r in reasons), *warnings]),
           "wall_time_s": record.wall_time_s, "verdict": record.verdict or ""}
    for key, column in (("date", "recorded"), ("temperature_c", "temperature_c"), ("operator", "operator"),
                        ("bench", "bench")):
        if conditions.get(key) is not None:
            row[column] = conditions[key]
    params = record.parameters
    for name, value, sigma in zip(params.names, params.values, params.sigma):
        row[name] = value
        row[f"{name}_sigma"] = sigma
    return row


def calibrate_unit(rec_path: str, out_dir: str, options: BatchOptions = BatchOptions()) -> dict:
    """Calibrate one unit; never raises: ``{"row": fleet row, "files": {path: bytes}}`` (no files on failure)."""
    try:
        rec = refine(read_recording(rec_path))
        noise = read_datasheet(options.noise) if options.noise else None
        sheet = read_acceptance_sheet(options.tolerance) if options.tolerance else None
        result = calibrate(rec, solver=options.solver, noise=noise, model=options.model)
        if result.distrust:  # no table the calibration's own checks do not trust
            raise CalibrationError("the calibration's own checks do not trust its result: "
                                   + " | ".join(result.distrust))
        verdict = judge(result.parameters, sheet) if sheet else None
        table = unit_table_path(out_dir, rec_path)
        files = {table: table_text(result.parameters, acceptance=verdict and verdict.outcome).encode()}
        files.update(report_files(result, rec, table, command="casadi-sins batch", unit_id=rec.conditions.unit_id or rec.name,
                                  verdict=verdict, certificate=options.certificate,
                                  table_sha256=hashlib.sha256(files[table]).hexdigest()))
        data = parse_report(files[report_path(table)], report_path(table))  # the ledger: names the table's SHA-256
        return {"row": row_from_report(data, rec_path, "ok"), "files": files}
    except Exception as exc:  # noqa: BLE001 (one failed unit never stops the batch: its reason is reported)
        message = one_line(exc, 500) or type(exc).__name__
        if not hasattr(exc, "path") and type(exc).__name__ not in ("CalibrationError",):
            message = f"{type(exc).__name__}: {message}"
        return {"row": {"unit_id": Path(rec_path).stem, "recording": str(rec_path), "status": "failed",
                        "warnings": 0, "message": message, "verdict": ""}, "files": {}}


def rejudged_unit(rec_path, out_dir, options: BatchOptions, data: dict) -> dict | None:
    """A finished unit judged again against this batch's sheet, from its stored table and report (no calibration):
    ``{"row", "files"}`` as :func:`calibrate_unit` gives, the table's acceptance column, the report's verdict and the
    certificate written anew; None when a certificate is asked for and the stored one holds no plots to carry
    over (the unit is then calibrated again)."""
    table = unit_table_path(out_dir, rec_path)
    with reading_own_outputs():  # the batch's own table, rewritten below with the new verdict
        params = read_table(table)
    sheet = read_acceptance_sheet(options.tolerance) if options.tolerance else None
    verdict = judge(params, sheet) if sheet else None
    plots = stored_plots(certificate_path(table)) if options.certificate else {}
    if plots is None:
        return None
    text = table_text(params, acceptance=verdict and verdict.outcome).encode()
    record = CalibrationRecord.of_report(data).judged(
        verdict and verdict.verdict, verdict and verdict.as_dict(),
        "judged again against the sheet from the stored table, not calibrated again")
    record = record.with_table(table, hashlib.sha256(text).hexdigest())
    files = {table: text}
    if options.certificate:
        files.update(certificate_files(record.report, table, options.certificate, plots))
    json_path, md_path = companion_paths(table)
    files[json_path] = record.report_json()
    files[md_path] = report_markdown(record.report).encode()
    return {"row": row_from_report(record.report, rec_path, "ok"), "files": files}


_PLOT = re.compile(r'<img alt="([^"]*)" src="data:image/png;base64,([A-Za-z0-9+/=]+)">')


def stored_plots(certificate: Path) -> dict[str, bytes] | None:
    """The plots of a stored HTML certificate (``{caption: png}``), None when there is none to read."""
    try:
        page = certificate.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    found = {html.unescape(caption): base64.b64decode(data) for caption, data in _PLOT.findall(page)}
    return found or None


def unit_files(out_dir, rec_path) -> list[Path]:
    """The output set of a unit under ``OUT/units/``: its table and every file of the table's stem
    (:func:`report.calibration.calibration_outputs`); those a new calibration does not write are removed with
    its writes, all of them when it failed (no stale table, certificate or export beside a failure)."""
    return calibration_outputs(unit_table_path(out_dir, rec_path))


#: The fleet's own files in OUT.
FLEET_FILES = ("fleet.csv", "fleet.md", "fleet-spread.csv", "fleet-spread.md")


def batch_outputs(out_dir, recordings: Sequence) -> list[Path]:
    """Every file a batch of ``recordings`` into ``out_dir`` may write or replace: the fleet tables and each
    unit's output set (:func:`unit_files`), to be claimed before any unit is calibrated."""
    return [Path(out_dir) / name for name in FLEET_FILES] + [p for rec in recordings for p in unit_files(out_dir, rec)]


def same_sheet(data: dict, options: BatchOptions) -> bool:
    """Whether a finished unit's report was judged against the sheet of this batch (or neither was judged)."""
    judged = CalibrationRecord.of_report(data).acceptance.get("sheet_sha256")
    return judged == (sheet_sha256(options.tolerance) if options.tolerance else None)


def check_unit_ids(recordings: Sequence) -> None:
    """Refuse two recordings of one unit id (a recording's ``name``), naming both; a recording whose name
    cannot be read is judged later, as that unit's failure.

    Raises
    ------
    InputError
        Naming both recordings and the id.
    """
    seen: dict[str, str] = {}
    for path in recordings:
        try:
            name = read_toml(path, "recording description").get("name")
        except InputError:
            continue
        if isinstance(name, str) and name in seen:
            raise InputError(path, f"unit id {one_line(repr(name), 80)} is also that of {seen[name]}: a batch "
                             "calibrates each unit once (give each recording its unit's own name)")
        if isinstance(name, str):
            seen[name] = str(path)


def run_batch(recordings: Sequence, out_dir, options: BatchOptions = BatchOptions(), workers: int | None = None,
              scheduler: str | None = None, progress: Callable[[int, int], None] | None = None,
              resume: bool = True) -> pd.DataFrame:
    """Calibrate every recording (resuming: finished units are read back, not recomputed); each unit's
    files are written as it finishes.  Returns the fleet table in the order of ``recordings``.

    Raises
    ------
    InputError
        When two recordings have the same file name (their units' files would be one).
    """
    paths = [str(Path(p).resolve()) for p in recordings]
    stems: dict[Path, str] = {}
    for path in paths:
        table = unit_table_path(out_dir, path)
        if table in stems:
            raise InputError(path, f"its unit's table would be {table.name}, as that of {stems[table]}: give the "
                             "recordings of a batch different file names")
        stems[table] = path
    check_unit_ids(recordings)
    rows: dict[str, dict] = {}
    pending = []
    for path in paths:
        data = finished(path, out_dir, options.certificate) if resume else None
        rejudged = rejudged_unit(path, out_dir, options, data) if data and not same_sheet(data, options) else None
        if rejudged is not None:  # another sheet: the stored table judged again, not calibrated again
            write_files(rejudged["files"], stale=unit_files(out_dir, path))  # no certificate of the old verdict
            rows[path] = {**rejudged["row"], "resumed": True, "rejudged": True}
        elif data is None or not same_sheet(data, options):
            pending.append(path)
        else:
            rows[path] = {**row_from_report(data, path, "ok"), "resumed": True}
    done = len(rows)
    if progress:
        progress(done, len(paths))

    def collect(result: dict) -> None:
        nonlocal done
        write_files(result["files"], stale=unit_files(out_dir, result["row"]["recording"]))
        rows[result["row"]["recording"]] = {**result["row"], "resumed": False}
        done += 1
        if progress:
            progress(done, len(paths))

    if pending and (workers != 1 or scheduler):  # compiled here once, not by every worker at the same time
        prepare_compiled(options.model, True)
    task = functools.partial(calibrate_unit, out_dir=str(out_dir), options=options)
    workers = min(workers or os.cpu_count() or 1, max(len(pending), 1)) if not scheduler else workers
    for result in run_all(task, pending, workers, scheduler) if pending else ():
        collect(result)
    return pd.DataFrame([rows[p] for p in paths])


def spread_frame(fleet: pd.DataFrame, threshold: float = OUTLIER_THRESHOLD) -> pd.DataFrame:
    """Per parameter across the units that calibrated: median, robust spread and outliers (natural units;
    scale factors in ppm about the median)."""
    ok = fleet[fleet["status"] != "failed"]
    names = [n for n in ALL_NAMES if n in ok.columns]  # the 21 and every extra group some unit has
    rows = []
    for name, scale, relative in zip(names, natural_scale_of(names), relative_mask(names)):
        units = ok[np.isfinite(ok[name].to_numpy(dtype=float))]  # units whose model had the parameter
        values = units[name].to_numpy(dtype=float)
        sigma = units[f"{name}_sigma"].to_numpy(dtype=float)
        median = float(np.median(values)) if len(values) else math.nan
        natural = (values / median - 1.0) / scale if relative else (values - median) / scale
        nat_sigma = sigma / (np.abs(values) if relative else 1.0) / scale
        robust = 1.4826 * float(np.median(np.abs(natural))) if len(values) else math.nan
        unit_sigma = float(np.nanmedian(nat_sigma)) if np.isfinite(nat_sigma).any() else 0.0
        reference = max(robust, unit_sigma)
        outliers = [u for u, x in zip(units["unit_id"], natural) if reference > 0 and abs(x) > threshold * reference]
        rows.append({"parameter": name, "unit": natural_unit_of(name), "units": len(values),
                     "median (SI)": median, "robust spread": robust, "std": float(np.std(natural, ddof=1))
                     if len(values) > 1 else math.nan, "min": float(natural.min()) if len(values) else math.nan,
                     "max": float(natural.max()) if len(values) else math.nan, "median unit sigma": unit_sigma,
                     "outliers": shlex.join(map(str, outliers))})
    return pd.DataFrame(rows, columns=SPREAD_COLUMNS)  # the columns even when no unit calibrated


def with_outliers(fleet: pd.DataFrame, spread: pd.DataFrame) -> pd.DataFrame:
    """The fleet table with an ``outliers`` column: each unit's parameters flagged in the spread."""
    flagged: dict[str, list[str]] = {}
    for name, units in zip(spread["parameter"], spread["outliers"]):
        for unit in shlex.split(str(units)):
            flagged.setdefault(unit, []).append(name)
    out = fleet.copy()
    out.insert(4, "outliers", [" ".join(flagged.get(str(u), [])) for u in out["unit_id"]])  # parameter names
    return out


def spread_display(spread: pd.DataFrame) -> pd.DataFrame:
    """The spread table as people read it: the median in the report's value units, rounded like every spread
    column to the median sigma of one unit; the spreads and that sigma to two significant digits."""
    frame = spread.copy()
    natural = [natural_value_of(n, v) for n, v in zip(frame["parameter"], frame["median (SI)"])]
    frame.insert(3, "median", [v for v, _ in natural])
    frame.insert(4, "value unit", [u for _, u in natural])
    frame["_sigma"] = [sigma_in_value_unit(n, v, s) for n, (v, _), s in
                       zip(frame["parameter"], natural, frame["median unit sigma"])]
    shown = display(frame, {"median": "_sigma", "min": "median unit sigma", "max": "median unit sigma"},
                    sigmas=["robust spread", "std", "median unit sigma"], signed=False)
    return shown.drop(columns=["median (SI)", "_sigma"]).rename(columns={"unit": "spread unit"})


def batch_files(fleet: pd.DataFrame, spread: pd.DataFrame, out_dir) -> dict[Path, bytes]:
    """``fleet.csv`` (every value and sigma, full precision), ``fleet.md`` (status per unit) and
    ``fleet-spread.csv/.md``."""
    out = Path(out_dir)
    fleet, spread = _named_cells(fleet), _named_cells(spread)
    failed = int((fleet["status"] == "failed").sum())
    rejected = int((fleet["verdict"] == "fail").sum()) if "verdict" in fleet else 0
    counts = (f"{plural(len(fleet), 'unit')}, {failed} failed"
              + (f", {rejected} out of tolerance" if "verdict" in fleet and fleet["verdict"].any() else ""))
    files = frame_files(fleet, out / "fleet", counts)
    summary = fleet[[c for c in ("unit_id", "status", "verdict", "warnings", "outliers", "recorded",
                                     "temperature_c", "message", "resumed")
                     if c in fleet]]
    files[out / "fleet.md"] = frame_files(summary, out / "fleet", f"fleet: {counts}; values and sigma of every "
                                          "parameter in fleet.csv")[out / "fleet.md"]
    files.update(frame_files(spread, out / "fleet-spread", "spread of each parameter across the units (natural "
                             f"units; scale factors ppm about the median); outliers beyond {OUTLIER_THRESHOLD:g} x "
                             "max(robust spread, median unit sigma)", display=spread_display(spread)))
    return files


def _named_cells(frame: pd.DataFrame) -> pd.DataFrame:
    """The frame with every name cell (:data:`NAME_COLUMNS`) safe in a spreadsheet (no formula)."""
    out = frame.copy()
    for column in NAME_COLUMNS:
        if column in out:
            out[column] = [x if not isinstance(x, str) else spreadsheet_cell(x) for x in out[column]]
    return out
