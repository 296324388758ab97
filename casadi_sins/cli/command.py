"""What a command of ``casadi-sins`` is: one record holding every fact the command line needs about it.

A record names its arguments (a light function of :mod:`cli.arguments`) and its run function as
``"module:function"`` (relative to :mod:`casadi_sins.cli`), imported only when that command runs, so that
``--help`` loads nothing heavy.  The output guard, the progress options and the input scan read the record:
no list of command names is kept anywhere else.  A new command is its run function, its arguments and one
record in :data:`cli.registry.COMMANDS`.
"""

from __future__ import annotations

import dataclasses
import importlib
from pathlib import Path
from typing import Callable

#: What ``--out`` is: one file, a folder, a recording (``NAME.toml`` and its ``NAME.csv``), or no output.
OUTPUT_KINDS = ("file", "folder", "recording", "none")
#: Arguments that are never input files, whatever the command: its output and the command's name.
NEVER_INPUTS = frozenset({"out", "command"})


class CliError(Exception):
    """A failure to report to the user in one line, with a non-zero exit status."""


@dataclasses.dataclass(frozen=True)
class Command:
    """One command of the command line.

    Attributes
    ----------
    name : str
        The sub-command (``casadi-sins NAME``).
    help : str
        One line: the command list's entry and the start of its ``--help``.
    arguments : callable
        ``arguments(parser)`` adds its arguments (light: argparse and constants that import nothing heavy).
    run : str
        ``"module:function"`` under :mod:`casadi_sins.cli` (``".commands:cmd_calibrate"``): the function
        ``run(args) -> exit status``, imported when the command runs.
    output : {"file", "folder", "recording", "none"}
        What ``--out`` names (a folder's writability is checked as a folder).
    long : bool
        It takes long enough to report progress: ``--quiet`` and ``--no-progress``.
    incremental : bool
        It writes as it goes by design (a resumable ledger); every other command's files are gathered and
        written together at the end.
    not_inputs : tuple of str
        Its arguments that name no input file (beside :data:`NEVER_INPUTS`): output folders, names, formats,
        addresses.
    owns : str or None
        ``"module:function"`` giving the files it owns from its ``--out`` (a table's report, exports and
        certificate); default by ``output``: the file itself, a recording's two files, nothing for a folder
        (a folder's command claims what it finds itself).
    epilog : str or None
        The end of its ``--help`` (exit statuses).
    """

    name: str
    help: str
    arguments: Callable
    run: str
    output: str = "folder"
    long: bool = False
    incremental: bool = False
    not_inputs: tuple[str, ...] = ()
    owns: str | None = None
    epilog: str | None = None

    def __post_init__(self):
        if self.output not in OUTPUT_KINDS:
            raise ValueError(f"command {self.name}: output must be one of {', '.join(OUTPUT_KINDS)}")

    def function(self) -> Callable:
        """The run function, imported now."""
        return _named(self.run)

    def is_input(self, argument: str) -> bool:
        """Whether the argument ``argument`` (its ``dest``) may name an input file."""
        return argument not in NEVER_INPUTS and argument not in self.not_inputs

    def owned(self, out) -> list[Path]:
        """The files this command owns when its ``--out`` is ``out`` (:func:`core.files.claim_outputs`)."""
        if out is None or self.output in ("folder", "none") and self.owns is None:
            return []
        if self.owns is not None:
            paths = _named(self.owns)(out)
        elif self.output == "recording":
            paths = _named("..data.description:recording_paths")(out)
        else:
            paths = [out]
        return [Path(p) for p in paths]


def _named(reference: str) -> Callable:
    """The function ``"module:function"`` names (module relative to :mod:`casadi_sins.cli`)."""
    module, _, name = reference.partition(":")
    return getattr(importlib.import_module(module, __package__), name)
