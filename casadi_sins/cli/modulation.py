"""The rotation-modulation commands ``modulate`` and ``modulate-mc``: read the arguments, call
:mod:`casadi_sins.studies.modulation`, print what it found.  No physics here."""

from __future__ import annotations

import math
import sys

from ..core.earth import Site
from ..core.files import write_files
from ..core.text import one_line
from ..core.units import DEG
from ..studies.modulation import model
from ..studies.modulation.analysis import analyse
from ..studies.modulation.calibrated import table_sources
from ..studies.modulation.montecarlo import montecarlo_files, run_schemes
from ..studies.modulation.outputs import COMPARISON, NAUTICAL_MILE, modulation_files
from ..studies.modulation.schemes import CLOSURE_TOL, closure_error, load_scheme
from ..studies.modulation.sources import load_sheet
from .commands import CliError
from .logs import progress_for


def _finite(args, *names: str) -> None:
    """Refuse a non-finite number given for any of the options ``names``."""
    for name in names:
        value = getattr(args, name, None)
        if value is not None and not math.isfinite(value):
            raise CliError(f"--{name.replace('_', '-')} must be a finite number (got {value})")


def site_and_sources(args):
    """The site and the error sources of ``--latitude``, ``--height``, ``--errors``, ``--params``,
    ``--covariance``."""
    _finite(args, "hours", "latitude", "height")
    site = model.check_site(Site(args.latitude * DEG, args.height))
    if not args.errors and not args.params:
        raise CliError("give the residual errors: --errors SHEET (a file or a shipped name) or --params P.csv")
    if args.covariance and not args.params:
        raise CliError("--covariance goes with --params (the covariance of a calibrated table)")
    sheet = load_sheet(args.errors) if args.errors else None
    if not args.params:
        return site, sheet
    sources = table_sources(args.params, args.covariance, sheet)
    if sheet is None:
        print("note: no --errors sheet with the table: initial attitude errors and sensor noise are zero",
              file=sys.stderr)
    return site, sources


def schemes_of(args, warnings: list[str]):
    """The ``--scheme`` schemes; a scheme that does not close is a warning (printed and kept), or with
    ``--strict`` a failure."""
    schemes = [load_scheme(s) for s in args.scheme]
    names = [s.name for s in schemes]
    if len(set(names)) != len(names):
        raise CliError(f"two schemes share a name ({', '.join(names)}): give each file its own name")
    if COMPARISON in names:
        raise CliError(f"a scheme may not be named {COMPARISON!r} (the name of the comparison plot)")
    for s in schemes:
        off = closure_error(s)
        if off >= CLOSURE_TOL:
            msg = (f"scheme {s.name} ({one_line(s.source)}) does not return to its start attitude after one period "
                   f"(off by {math.degrees(off):.4g} deg): each period continues from where the last ended")
            if args.strict:
                raise CliError(msg + " (--strict)")
            warnings.append(msg)
            print(f"warning: {msg}", file=sys.stderr)
    return schemes


def cmd_modulate(args) -> int:
    """``modulate``: the covariance of each scheme's navigation error, by source, and its files."""
    _finite(args, "turn_step_deg", "output_step_s")
    warnings: list[str] = []
    site, sources = site_and_sources(args)
    schemes = schemes_of(args, warnings)
    doc, results = analyse(schemes, sources, site, args.hours, args.turn_step_deg, args.output_step_s,
                           aligned=args.initial == "aligned")
    doc["warnings"] = warnings
    write_files(modulation_files(doc, results, args.out, plots=not args.no_plots))
    for name, s in doc["schemes"].items():
        print(f"{name}: max horizontal position error {s['max_horizontal_position_error_m']:.4g} m "
              f"({s['max_horizontal_position_error_m'] / NAUTICAL_MILE:.3g} nmi) at {s['time_of_max_h']:.3g} h, "
              f"max velocity error {s['max_velocity_error_mps']:.3g} m/s; computed in {s['compute_s']:.2f} s")
    print(f"wrote {args.out}/modulation.{{json,md}}" + ("" if args.no_plots else " and plots"))
    return 0


def cmd_modulate_mc(args) -> int:
    """``modulate-mc``: the time-domain Monte Carlo against the covariance, per source group."""
    _finite(args, "turn_step_deg")
    if args.runs < 2:
        raise CliError(f"--runs must be at least 2 (got {args.runs})")
    if args.workers < 1:
        raise CliError(f"--workers must be at least 1 (got {args.workers})")
    warnings: list[str] = []
    site, sources = site_and_sources(args)
    schemes = schemes_of(args, warnings)
    with progress_for(args, len(schemes), "modulate-mc", "scheme") as progress:
        results = run_schemes(schemes, sources, site, args.hours, aligned=args.initial == "aligned",
                              workers=args.workers, runs=args.runs, seed=args.seed, turn_step_deg=args.turn_step_deg,
                              matched=not args.plain, progress=progress)
    write_files(montecarlo_files(results, warnings, args.out))
    for res in results:
        for group, v in res["groups"].items():
            if "note" not in v:
                print(f"{res['scheme']}: {group}: MC/covariance {v['ratio_of_max']:.3f} "
                      f"(pooled {v['ratio_pooled']:.3f})")
    print(f"wrote {args.out}/montecarlo.{{json,md}}")
    return 0
