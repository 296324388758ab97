"""The command ``design-scheme``: read the arguments, call :mod:`casadi_sins.studies.modulation.designer`,
write what it found.  No physics here."""

from __future__ import annotations

from ..core.files import write_files
from ..core.units import DEG
from ..studies.modulation.design import Request
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
