"""The production-line commands: ``apply``, ``history``, ``batch``, and ``navcheck`` / ``budget`` on a
unit's own recording.  Parsing and printing only; the work is in :mod:`studies`."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ..studies.parallel import check_scheduler
from ..core.files import claim_outputs, write_files
from ..core.guard import register_inputs
from ..data.description import is_recording_description, read_recording
from ..data.segmentation import refine
from ..data.tables import read_table
from ..core.errors import InputError
from ..data.tolerance import read_tolerance_sheet
from ..report.acceptance import read_acceptance_sheet
from ..report.provenance import read_provenance
from ..report.rounding import format_sigma, format_with_sigma
from ..studies.apply import Z_LIMIT as APPLY_Z_LIMIT
from ..studies.apply import apply_files, check_display, table_with_covariance
from ..studies.batch import BatchOptions, batch_files, batch_outputs, run_batch, spread_frame, with_outliers
from ..studies.history import history_files, load_history
from ..studies.unitcheck import recording_budget_files, recording_navigation_files
from .commands import CliError, cmd_budget, cmd_navcheck
from .inputs import recording_inputs
from .logs import note, progress_for
from .thermal import applied_recording, apply_inputs


def cmd_apply(args) -> int:
    """``apply``: a recording compensated with a table, and its check against gravity and the Earth rate."""
    table, recording = apply_inputs(args)
    rec = refine(read_recording(recording))
    applied = applied_recording(args, table, rec)
    origin = read_provenance(table)
    write_files(apply_files(applied, args.out, str(table), origin.table_sha256))
    if not applied.check.empty:
        print(check_display(applied.check).to_string(index=False))
    for text in applied.notes:
        note(text)
    worst = applied.worst()
    print(f"worst static segment: gravity {worst.get('gravity_error_ug', float('nan')):.3g} ug, Earth rate "
          f"{worst.get('earth_rate_error_deg_h', float('nan')):.3g} deg/h (noise of each mean and the table's sigma "
          "in the check table)")
    print(f"wrote {args.out}/{applied.recording.file_stem}.{{toml,csv}} (increments in rad and m/s) and its check")
    verdict, reasons = applied.verdict()
    if verdict is None:
        return 0
    z = applied.check[["gravity_z", "earth_rate_z"]].abs().max().max()
    print(f"verdict: {verdict.upper()}: worst static segment {z:.2g} sigma from gravity and the Earth rate (noise of "
          f"the mean and the table's sigma), limit {APPLY_Z_LIMIT:g}")
    for reason in reasons:
        print(f"  {reason}")
    return 3 if verdict == "fail" else 0


def cmd_history(args) -> int:
    """``history``: one unit's calibrations side by side by date."""
    sheet = read_tolerance_sheet(args.tolerance) if args.tolerance else None
    cals, notes = load_history(args.tables)
    files, summary = history_files(cals, args.out, sheet, notes)
    write_files(files)
    for text in notes:
        note(text)
    shown = summary.copy()
    shown["change"] = [format_with_sigma(c, s, signed=True) for c, s in zip(shown["change_first_to_last"],
                                                                           shown["combined_sigma"])]
    shown["drift_per_year"] = [format_with_sigma(d, s, signed=True) for d, s in zip(shown["drift_per_year"],
                                                                                   shown["drift_sigma_per_year"])]
    shown["combined_sigma"] = [format_sigma(s) for s in shown["combined_sigma"]]
    cols = ["parameter", "unit", "change", "combined_sigma", "z_first_to_last", "max_abs_z", "drift_per_year",
            "flagged", "status"]
    print(shown[cols].to_string(index=False, float_format=lambda x: f"{x:+.2f}"))  # z
    flagged = list(summary.loc[summary["flagged"], "parameter"])
    failed = list(summary.loc[summary["status"] == "fail", "parameter"])
    print(f"{len(cals)} calibrations; changed beyond {sheet.z_limit if sheet else 4.0:g} sigma: "
          f"{', '.join(flagged) or 'none'}" + (f"; out of tolerance: {', '.join(failed) or 'none'}" if sheet else ""))
    print(f"wrote {args.out}/history-*.{{csv,md,png}}")
    return 0


def cmd_batch(args) -> int:
    """``batch``: every recording calibrated, the fleet table and the spread across units."""
    check_scheduler(args.dask)  # before any work or progress bar
    if args.tolerance:
        read_acceptance_sheet(args.tolerance)  # a bad sheet stops the batch before any unit
    recordings = batch_recordings(args.recordings)
    claim_outputs(batch_outputs(args.out, recordings))  # before any unit: no output over a recording found
    options = BatchOptions(solver=args.solver, model=args.model, noise=args.noise,
                           tolerance=args.tolerance and str(Path(args.tolerance).resolve()),
                           certificate=args.certificate)
    t0 = time.perf_counter()
    with progress_for(args, len(recordings), "batch", "unit") as progress:
        fleet = run_batch(recordings, args.out, options, args.workers, args.dask, progress=progress,
                          resume=not args.no_resume)
    spread = spread_frame(fleet)
    fleet = with_outliers(fleet, spread)
    write_files(batch_files(fleet, spread, args.out))
    cols = ["unit_id", *(["temperature_c"] if "temperature_c" in fleet else []), "status",
            *(["verdict"] if args.tolerance else []), "warnings", "outliers", "message"]
    print(fleet[cols].to_string(index=False, max_colwidth=100))
    failed = int((fleet["status"] == "failed").sum())
    rejected = int((fleet["verdict"] == "fail").sum()) if "verdict" in fleet else 0
    resumed = int(fleet["resumed"].fillna(False).astype(bool).sum()) if "resumed" in fleet else 0
    rejudged = int(fleet["rejudged"].fillna(False).astype(bool).sum()) if "rejudged" in fleet else 0
    print(f"{len(fleet)} units in {time.perf_counter() - t0:.1f} s: {failed} failed"
          + (f", {rejected} out of tolerance" if args.tolerance else "") + f", {resumed} already done "
          f"(not recomputed{f'; {rejudged} of them judged again against the sheet' if rejudged else ''}); wrote {args.out}/fleet.{{csv,md}}, fleet-spread.{{csv,md}} and units/")
    return 2 if failed else 3 if rejected else 0


def batch_recordings(paths) -> list[str]:
    """The recordings of ``batch``: files as given, and in a folder given every ``*.toml`` in name order that
    is a recording description or cannot be read as TOML (it becomes a failed unit, never silently left
    out); a TOML file of another kind (a problem file, a tolerance sheet) is named in a note and left out.
    Each recording found, and the data file it names, is an input of the command (:mod:`core.guard`)."""
    out = []
    for path in map(Path, paths):
        if not path.is_dir():
            out.append(str(path))
            continue
        found = []
        for toml in sorted(path.glob("*.toml")):
            try:
                if not is_recording_description(toml):
                    print(f"note: {toml}: not a recording description (no format = \"sins-recording/1\"): left "
                          "out of the batch", file=sys.stderr)
                    continue
            except InputError:
                pass  # unreadable: calibrated as a unit, which fails naming the fault
            found.append(str(toml))
        if not found:
            raise CliError(f"{path}: no recording description (*.toml, format sins-recording/1) in the folder")
        out += found
    for rec in out:
        register_inputs(recording_inputs(rec))
    return out


def cmd_navcheck_any(args) -> int:
    """``navcheck``: on a problem (simulated) or on a unit's recording with its tables."""
    if not (args.problem and is_recording_description(args.problem)):
        args.duration_s = 3600.0 if args.duration_s is None else args.duration_s
        return cmd_navcheck(args)
    rec = read_recording(args.problem)
    tables = {Path(p).stem: read_table(p).values for p in args.params}
    files, shown = recording_navigation_files(rec, tables, args.out, args.align_s, args.duration_s)
    write_files(files)
    print(shown.to_string(index=False))
    print(f"wrote {args.out}/{rec.file_stem}-navcheck.{{csv,md,png}}")
    return 0


def cmd_budget_any(args) -> int:
    """``budget``: on a problem, or on a unit's recording with its table."""
    from ..studies.budget import MAX_HOURS
    if not 0 < args.hours <= MAX_HOURS:
        raise CliError(f"--hours must be a positive number of at most {MAX_HOURS:g} (six weeks), found {args.hours:g}")
    if not (args.problem and is_recording_description(args.problem)):
        args.orientation = args.orientation or "ENU"
        return cmd_budget(args)
    if not args.params:
        raise CliError(f"{args.problem}: a recording's budget needs the unit's table: --params P.csv")
    rec = read_recording(args.problem)
    params = table_with_covariance(args.params)  # the correlations of its report, when it has one
    if params.sigma is None:
        raise CliError(f"{args.params}: the table has no sigma column; the budget needs the uncertainty")
    budget = recording_budget_files(rec, params, args.params, args.out, args.orientation, args.hours)
    write_files(budget.files)
    print(f"measured white noise: {budget.noise}; "
          f"orientation {budget.orientation}; parameter uncertainty from {args.params} ({budget.correlations})")
    print(budget.shown.to_string(index=False))
    print(f"wrote {args.out}/{rec.file_stem}-budget.{{csv,md,png}}")
    return 0
