"""The output set a command owns before it computes anything (:func:`core.files.claim_outputs`).

A command that writes a table owns every file of the table's stem it may write; those it does not write
again are removed with its writes (so no certificate or export of an earlier run contradicts a new
table).  Commands whose outputs depend on what they find (``batch``: the recordings of a folder) claim
them themselves once found.
"""

from __future__ import annotations

from pathlib import Path

from .registry import command


def command_outputs(args) -> list[Path]:
    """The files ``args``' command owns (empty for a command that claims its own or writes a folder):
    :meth:`cli.command.Command.owned` of its ``--out``."""
    return command(args.command).owned(getattr(args, "out", None))
