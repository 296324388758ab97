"""The command line ``casadi-sins``: parsing and printing only; the work is done by the library."""

from __future__ import annotations

import sys

from ..calibrate.result import CalibrationError
from ..core.errors import InputError, OutputError
from ..core.files import check_writable
from ..core.threads import single_threaded
from .commands import CliError
from .parser import build_parser

#: Commands whose --out is a folder (the others write one file).
FOLDER_OUTPUTS = {"simulate", "navigate", "compare", "analyze", "montecarlo", "navcheck", "budget", "demo", "apply",
                  "history", "batch"}

__all__ = ["main", "build_parser", "CliError"]


def main(argv: list[str] | None = None) -> int:
    """Run ``casadi-sins`` with ``argv``; returns the exit status (0, 2 for a failure told in one line,
    130 interrupted)."""
    args = build_parser().parse_args(argv)
    try:
        if getattr(args, "out", None):
            check_writable(args.out, directory=args.command in FOLDER_OUTPUTS)  # before any computation
        with single_threaded():
            return args.func(args)
    except (InputError, OutputError, CliError, CalibrationError) as exc:
        print(f"casadi-sins {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except OSError as exc:  # a file system failure: one line naming the file, never a traceback
        where = exc.filename or ""
        print(f"casadi-sins {args.command}: error: {where}{': ' if where else ''}{exc.strerror or exc}",
              file=sys.stderr)
        return 2
