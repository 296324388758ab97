"""The command line's arguments: every command, option and argument with its help, built from the records of
:mod:`cli.registry`.  Light: building the parser and ``--help`` import nothing heavy."""

from __future__ import annotations

import argparse
import os

from ..core.version import build_identity
from .logs import add_log_options
from .registry import COMMANDS


class _PrintVersion(argparse.Action):
    """``--version``: the build identity on one line (argparse's own action would wrap it)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(build_identity())
        parser.exit()


class Parser(argparse.ArgumentParser):
    """argparse's parser, but a bad argument is one line (the command and what is wrong, where to look), exit 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``casadi-sins``: one sub-command per record of :data:`cli.registry.COMMANDS`."""
    parser = Parser(
        prog="casadi-sins",
        description="System-level calibration of strapdown inertial navigation systems (21-parameter model).")
    parser.add_argument("--version", action=_PrintVersion, nargs=0, help="print the build (version, commit) and exit")
    sub = parser.add_subparsers(dest="command", required=True)
    for record in COMMANDS:  # each command's --help starts with its one-line description
        p = sub.add_parser(record.name, help=record.help, description=record.help, epilog=record.epilog)
        record.arguments(p)
        if record.long:
            add_log_options(p)
    _finite_numbers(parser)
    return parser


def finite_float(text: str) -> float:
    """A number option: an ASCII decimal number, finite (``nan``, ``inf`` and ``1_000`` are refused by argparse
    in one line, before any command runs)."""
    from ..core.text import decimal_number

    try:
        return decimal_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite decimal number") from None


def counted(low: int, high: int, what: str):
    """An integer option within ``[low, high]`` (``what`` says why the bound)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{value} is not between {low} and {high} ({what})")
        return value
    return parse


#: Bounds of the integer options, by name: a seed is what NumPy's generator takes; more worker processes than
#: four per core gain nothing (and a typing error must not start a million processes).
INTEGER_OPTIONS = {"seed": (0, 2**63 - 1, "a random seed"), "first_seed": (0, 2**63 - 1, "a random seed"),
                   "workers": (1, 4 * (os.cpu_count() or 1), "worker processes, at most four per core"),
                   "max_iterations": (1, 10_000, "iterations of a solver"),
                   "runs": (1, 100_000, "Monte Carlo runs, each a simulation"), "verify": (0, 100_000, "Monte Carlo runs")}


def _finite_numbers(parser: argparse.ArgumentParser) -> None:
    """Every ``type=float`` option of every command reads through :func:`finite_float`, every seed and worker
    count within :data:`INTEGER_OPTIONS`."""
    for action in parser._actions:  # noqa: SLF001 (argparse keeps its actions there; no public walk)
        if action.type is float:
            action.type = finite_float
        if action.type is int and action.dest in INTEGER_OPTIONS:
            action.type = counted(*INTEGER_OPTIONS[action.dest])
        for child in (action.choices or {}).values() if isinstance(action.choices, dict) else ():
            _finite_numbers(child)
