"""The command ``design-scheme``: read the arguments, call :mod:`casadi_sins.studies.modulation.designer`,
write what it found.  No physics here."""

from __future__ import annotations


from ..core.files import write_files
from ..core.units import DEG
from ..studies.modulation.design import CRITERIA, Request
from .commands import CliError
from .logs import message_printer
from .modulation import _finite, site_and_sources


def cmd_design_scheme(args) -> int:
    """``design-scheme``: search rotation sequences for the smallest navigation error; scheme.toml and
    design.json/.md."""
    from ..studies.modulation.design_report import design_files  # the search loads only when it runs
    from ..studies.modulation.designer import design
    _finite(args, "rate_deg_s", "stop_s")
    if args.samples < 1:
        raise CliError(f"--samples must be at least 1 (got {args.samples})")
    site, sources = site_and_sources(args)
    req = Request(args.positions, args.axes, args.rate_deg_s * DEG, args.stop_s, args.hours, args.criterion)

    result = design(req, sources, site, samples=args.samples, seed=args.seed,
                    progress=message_printer(args, "design-scheme"))
    write_files(design_files(result, sources, site, args.out))
    print(f"designed {result.best.notation()} (first turn after {result.best.dwell0:g} s): {req.criterion} "
          f"{result.best.value:.4g} in {result.seconds:.1f} s")
    print(f"wrote {args.out}/scheme.toml and design.{{json,md}}")
    return 0


def add_design_command(sub) -> None:
    """Register ``design-scheme`` on the command line's subparsers."""
    p = sub.add_parser("design-scheme", help="design a rotation scheme: search sequences of 180 deg turns for the "
                       "smallest navigation error of the covariance; scheme.toml and design.json/.md")
    p.add_argument("--errors", metavar="SHEET", help="error sheet: a file or a shipped name (yu-ruan2014-sim, "
                   "guan2023-table1)")
    p.add_argument("--params", metavar="P.csv", help="calibrated parameter table: design for its residual errors "
                   "(its sigma or covariance); initial errors and noise from --errors, if given")
    p.add_argument("--covariance", metavar="C.csv", help="full covariance of the --params table (as modulate)")
    p.add_argument("--positions", type=int, required=True, help="stops per period (even: 180 deg turns must "
                   "return to the start)")
    p.add_argument("--axes", type=int, default=2, choices=(1, 2), help="1: the vertical IMU axis z alone; 2 "
                   "(default): z and a horizontal IMU axis (y and x both searched)")
    p.add_argument("--rate-deg-s", type=float, required=True, help="turn rate, deg/s")
    p.add_argument("--stop-s", type=float, required=True, help="stop after each turn, s")
    p.add_argument("--hours", type=float, required=True, help="length of the run, h")
    p.add_argument("--latitude", type=float, required=True, help="latitude of the static site, deg")
    p.add_argument("--height", type=float, default=0.0, help="height of the site, m (default 0)")
    p.add_argument("--criterion", choices=CRITERIA, default="position",
                   help="position (default): largest horizontal position error of the run; velocity: largest "
                   "horizontal velocity error; final: horizontal position error at the end of the run")
    p.add_argument("--samples", type=int, default=20000, help="random start sequences per inner axis "
                   "(default 20000; all of them when the space is small)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random start sequences (default 0)")
    p.add_argument("--out", required=True, help="output folder: scheme.toml, design.json, design.md")
    p.set_defaults(func=cmd_design_scheme)
