"""Outputs never over inputs: the registry of the files a command reads, and the checks of every place it
writes or removes.

While a command runs (:func:`guarded_inputs`), every input is registered by identity (device and inode,
so a link or a second hard link is the same file) as it is discovered: the files the command line names,
the recordings found in a folder, a description's data file, a table's companion report, and every file
a reader opens (:func:`core.inputs.check_input_file` registers it).  An output that is one of them, or an
existing output that is not a regular file (a device, a FIFO, a socket, or a link to one), is refused
before anything is written over it (:func:`check_output_target`); a file of an earlier run that the
command would remove is checked the same way first (:func:`check_removable`): no input is ever written
over or removed.
"""

from __future__ import annotations

import contextlib
import os
import stat
from pathlib import Path

from .errors import OutputError

#: ``(device, inode) -> (path as the user named it, its role or None)`` of the running command's inputs
#: (``None``: no command runs).
_INPUTS: dict[tuple[int, int], tuple[str, str | None]] | None = None
#: The input registered last by the running (or last) command: what it was reading, for a message.
_LAST: str | None = None


@contextlib.contextmanager
def guarded_inputs(paths=()):
    """Register ``paths`` (and, within the block, any :func:`register_input`) as inputs of one command."""
    global _INPUTS, _LAST
    previous, _INPUTS, _LAST = _INPUTS, {}, None
    try:
        register_inputs(paths)
        yield
    finally:
        _INPUTS = previous


def register_inputs(items) -> None:
    """:func:`register_input` of each item: a path, or ``(path, role)``."""
    for item in items:
        register_input(*(item if isinstance(item, tuple) else (item,)))


def register_input(path, role: str | None = None) -> None:
    """Remember an existing input file (nothing when no command runs or the file does not exist);
    ``role`` names it in messages (``"the samples of unit42.toml"``)."""
    if _INPUTS is None:
        return
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return
    if stat.S_ISREG(info.st_mode):
        global _LAST
        _INPUTS.setdefault((info.st_dev, info.st_ino), (str(path), role))
        _LAST = str(path)


@contextlib.contextmanager
def reading_own_outputs():
    """Within the block, files read are not registered as inputs: a command reading back what it wrote
    itself in an earlier run and owns (``batch``'s stored tables, judged again against a new sheet, are
    rewritten with the new verdict)."""
    global _INPUTS
    previous, _INPUTS = _INPUTS, None
    try:
        yield
    finally:
        _INPUTS = previous


def last_input() -> str | None:
    """The input the running command (or the last one) registered last: the file it was reading or had read
    last, to name in a message about memory."""
    return _LAST


def input_role(path) -> str | None:
    """How the running command came to read ``path`` (``"it is X"``, its role), ``""`` for an input with no
    role, or None when ``path`` is not one of its inputs (or does not exist)."""
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return None
    found = (_INPUTS or {}).get((info.st_dev, info.st_ino))
    if found is None:
        return None
    source, role = found
    same = [] if os.path.abspath(source) == os.path.abspath(path) else [f"it is {source}"]
    return ", ".join(same + ([role] if role else []))


def check_output_target(path) -> None:
    """Refuse an output that is an input of the running command, or an existing non-regular file.

    Raises
    ------
    OutputError
        One line naming ``path`` (and the input it would overwrite).
    """
    if _existing_file(path, "replace it") is not None:
        _refuse_input(path, "refusing to write over it")


def check_removable(path) -> bool:
    """Whether ``path`` (a file of an earlier run that the running command owns and does not write again)
    exists to be removed; refuse when it is an input of the command or not a regular file.

    Raises
    ------
    OutputError
        One line naming ``path`` (and the input it is).
    """
    found = _existing_file(path, "remove it")
    if found is None:
        return False
    if found:  # a dangling link needs no check: removing the link loses nothing
        _refuse_input(path, "also a file this command writes or replaces: refusing to remove it")
    return True


def _existing_file(path, doing: str) -> bool | None:
    """None when ``path`` does not exist, False for a dangling link, True for a regular file; anything else (a
    folder, a device, a FIFO, a socket, a link to one) is refused, naming what would be done to it."""
    path = Path(path)
    if not os.path.lexists(path):
        return None
    try:
        info = os.stat(path)
    except OSError:
        return False
    if stat.S_ISDIR(info.st_mode):
        raise OutputError(f"{path}: is a folder, not a file to write: refusing to {doing}")
    if not stat.S_ISREG(info.st_mode):
        raise OutputError(f"{path}: is not a regular file (a device, FIFO or socket, or a link to one): refusing to "
                          f"{doing}")
    return True


def _refuse_input(path, what: str) -> None:
    role = input_role(path)
    if role is not None:
        raise OutputError(f"{path}: is an input of this command{f' ({role})' if role else ''}: {what}; choose "
                          "another output name")
