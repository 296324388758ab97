"""The ``thermal`` command: one unit's calibrations at several temperatures into a temperature model.
Parsing and printing only; the work is in :mod:`studies.thermal`."""

from __future__ import annotations

import argparse

from ..core.files import write_files
from ..model.registry import natural_unit_of
from ..report.rounding import format_sigma, format_with_sigma
from ..studies.thermal.fit import fit_thermal
from ..studies.thermal.inputs import load_points
from ..studies.thermal.outputs import at_name, natural_coefficients, thermal_files


def add_thermal_command(sub) -> None:
    """The ``thermal`` sub-command and its options."""
    p = sub.add_parser("thermal", help="a temperature model per parameter from one unit's calibrations at several "
                       "temperatures: thermal.csv, thermal.md, plots, and tables at chosen temperatures")
    p.add_argument("tables", nargs="+", metavar="TABLE.csv[@T]",
                   help="parameter tables of one unit (their NAME.report.json gives the full covariance and the "
                   "temperature, conditions.temperature_c); NAME.csv@25 gives the temperature (degC) explicitly")
    p.add_argument("--temperatures", type=float, nargs="+", metavar="T",
                   help="temperature of each table, degC, in the order of the tables (instead of the reports')")
    p.add_argument("--order", choices=("auto", "1", "2"), default="auto",
                   help="polynomial order per parameter: auto (by evidence, default), 1 or 2 for all")
    p.add_argument("--reference-c", type=float, default=25.0, help="reference temperature T_ref, degC (default 25)")
    p.add_argument("--at", type=float, nargs="+", default=[], metavar="T",
                   help="write the parameter table at each temperature T (degC): DIR/at-<T>C.csv")
    p.add_argument("--no-plots", action="store_true", help="leave out the plots")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_thermal)


def cmd_thermal(args: argparse.Namespace) -> int:
    """``thermal``: fit, write every file together, print the coefficients and the warnings."""
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
        print(f"warning: {text}")
    for text in notes:
        print(f"note: {text}")
    written = ["thermal.csv", "thermal.json", "thermal.md"] + [at_name(t) for t in args.at]
    print(f"wrote {args.out}/{{{','.join(written)}}}" + ("" if args.no_plots else " and plots"))
    return 0
