"""The ``thermal`` command: one unit's calibrations at several temperatures into a temperature model.
Parsing and printing only; the work is in :mod:`studies.thermal`."""

from __future__ import annotations

import argparse

from ..core.files import atomic_write_text, write_files
from ..data.conditions import TEMPERATURE_RANGE_C
from ..data.thermal import is_thermal_model
from ..data.thermal_problem import has_thermal, load_thermal_problem
from ..model.registry import natural_unit_of
from ..core.text import one_line
from ..report.provenance import thermal_provenance
from ..report.rounding import format_sigma, format_with_sigma
from ..studies.apply import Applied, apply_table, table_with_covariance
from .commands import CliError, cmd_export, cmd_simulate
from .logs import note, warning


def cmd_thermal(args: argparse.Namespace) -> int:
    """``thermal``: fit, write every file together, print the coefficients and the warnings."""
    from ..studies.thermal.fit import fit_thermal  # the thermal modules load only for thermal work
    from ..studies.thermal.inputs import load_points
    from ..studies.thermal.outputs import at_name, natural_coefficients, thermal_files
    low, high = TEMPERATURE_RANGE_C
    for t in [args.reference_c, *args.at]:
        if not low <= t <= high:
            raise CliError(f"temperature {t:g} degC (--reference-c or --at) is outside {low:g}..{high:g} degC")
    points, notes, unit_id = load_points(args.tables, args.temperatures)
    fit = fit_thermal(points, order=args.order, reference_c=args.reference_c)
    model = fit.model
    extrapolated = [t for t in args.at if model.extrapolates(t)]
    if extrapolated:
        fit.warnings.append(f"--at {', '.join(f'{t:g}' for t in extrapolated)} degC: extrapolated beyond the "
                            f"calibrated range {model.range_c[0]:g} .. {model.range_c[1]:g} degC")
    write_files(thermal_files(fit, args.out, list(args.at), notes, unit_id, plots=not args.no_plots))
    coef, sig = natural_coefficients(model)
    print(f"{len(points)} calibrations, {', '.join(f'{p.temperature_c:g}' for p in points)} degC; "
          f"T_ref {model.reference_c:g} degC")
    print(f"{'parameter':22s} {'unit':8s} {'a1 per degC':>18s} {'a2 per degC^2':>22s} order")
    for i, name in enumerate(model.names):
        unit = natural_unit_of(name)
        print(f"{name:22s} {unit:8s} {format_with_sigma(coef[i, 1], sig[i, 1], signed=True):>10s} "
              f"+- {format_sigma(sig[i, 1]):7s} {format_with_sigma(coef[i, 2], sig[i, 2], signed=True):>12s} "
              f"+- {format_sigma(sig[i, 2]):7s} {model.orders[i]}")
    for text in fit.warnings:
        warning(text)
    for text in notes:
        note(text)
    written = ["thermal.csv", "thermal.json", "thermal.md"] + [at_name(t) for t in args.at]
    print(f"wrote {args.out}/{{{','.join(written)}}}" + ("" if args.no_plots else " and plots"))
    return 0


def apply_inputs(args) -> tuple[str, str]:
    """``(table or thermal model, recording)`` of ``apply``: with ``--thermal`` the one positional is the recording."""
    given = [a for a in (args.table, args.recording) if a is not None]
    if args.thermal:
        if len(given) != 1:
            raise CliError("with --thermal give the recording alone (the thermal model replaces the table)")
        return args.thermal, given[0]
    if args.temperature_c is not None:
        raise CliError("--temperature-c goes with --thermal (a table is of one temperature)")
    if len(given) != 2:
        raise CliError("apply needs a parameter table and a recording (or --thermal thermal.csv and a recording)")
    return args.table, args.recording


def applied_recording(args, table: str, rec) -> Applied:
    """The recording compensated with the table, or with the thermal model (at ``--temperature-c``, else at the
    recording's temperature: :func:`studies.thermal.apply.apply_thermal_at_recording`)."""
    from ..data.thermal import read_thermal
    from ..studies.thermal.apply import apply_thermal_at_recording
    if not args.thermal:
        return apply_table(rec, table_with_covariance(table))
    return apply_thermal_at_recording(rec, read_thermal(table), table, args.temperature_c, "--temperature-c")


def cmd_export_any(args) -> int:
    """``export``: a parameter table (:func:`commands.cmd_export`), or a thermal model as a C header."""
    from ..data.thermal import read_thermal
    from ..report.cheader_thermal import c_header_thermal
    if not is_thermal_model(args.table):
        return cmd_export(args)
    if args.format != "c":
        raise CliError(f"{args.table}: a thermal model exports as --format c (casadi_sins_compensate_t); for the "
                       f"{args.format} form of one temperature use thermal --at T and export that table")
    model = read_thermal(args.table)
    metadata = thermal_provenance(args.table)  # hashes, dates, versions, the calibrations (as every export)
    if args.unit_id and metadata.get("unit_id") and args.unit_id != metadata["unit_id"]:
        raise CliError(f"{args.table}: --unit-id {one_line(args.unit_id, 60)} but the thermal model is of unit "
                       f"{one_line(metadata['unit_id'], 60)}")
    metadata = {"unit_id": args.unit_id or metadata.get("unit_id"), **metadata}
    try:
        text = c_header_thermal(model, metadata)
    except ValueError as exc:
        raise CliError(f"{args.table}: {exc}") from None
    atomic_write_text(args.out, text)
    print(f"wrote {args.out} (c, thermal: casadi_sins_compensate_t)")
    return 0


def cmd_simulate_any(args) -> int:
    """``simulate``: a problem (:func:`commands.cmd_simulate`), or a thermal problem: one recording per setpoint."""
    from ..studies.thermal.simulate import simulate_thermal, thermal_simulation_files
    if not has_thermal(args.problem):
        return cmd_simulate(args)
    if args.start_attitude_deg is not None or args.quantize or args.name:
        raise CliError("--start-attitude-deg, --quantize and --name are for a single recording; set them in the "
                       "thermal problem's [errors] and name")
    tp = load_thermal_problem(args.problem)
    sims = simulate_thermal(tp, seed=args.seed, noise=not args.no_noise)
    write_files(thermal_simulation_files(tp, sims, args.out))
    for sim in sims:
        print(f"wrote {args.out}/{sim.recording.file_stem}.toml (+ .csv, .truth.csv): "
              f"{sim.recording.conditions.temperature_c:g} degC")
    print(f"wrote {args.out}/thermal-truth.csv (the unit's true temperature model)")
    return 0
