"""Outputs never over inputs: the files a command reads, and the checks of every place it writes.

While a command runs (:func:`guarded_inputs`), every input it names is registered by identity
(device and inode, so a link or a second hard link is the same file); an output that is one of them,
or an existing output that is not a regular file (a device, a FIFO, a socket, or a link to one), is
refused before anything is written over it.
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


@contextlib.contextmanager
def guarded_inputs(paths=()):
    """Register ``paths`` (and, within the block, any :func:`register_input`) as inputs of one command."""
    global _INPUTS
    previous, _INPUTS = _INPUTS, {}
    try:
        for path in paths:
            register_input(*(path if isinstance(path, tuple) else (path,)))
        yield
    finally:
        _INPUTS = previous


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
        _INPUTS.setdefault((info.st_dev, info.st_ino), (str(path), role))


def check_output_target(path) -> None:
    """Refuse an output that is an input of the running command, or an existing non-regular file.

    Raises
    ------
    OutputError
        One line naming ``path`` (and the input it would overwrite).
    """
    path = Path(path)
    if not os.path.lexists(path):
        return
    try:
        info = os.stat(path)
    except OSError:
        return  # a dangling link: replacing the link loses nothing
    if stat.S_ISDIR(info.st_mode):
        raise OutputError(f"{path}: is a folder, not a file to write")
    if not stat.S_ISREG(info.st_mode):
        raise OutputError(f"{path}: is not a regular file (a device, FIFO or socket, or a link to one): refusing "
                          "to replace it")
    found = (_INPUTS or {}).get((info.st_dev, info.st_ino))
    if found is not None:
        source, role = found
        same = [] if os.path.abspath(source) == os.path.abspath(path) else [f"it is {source}"]
        what = f" ({', '.join(same + ([role] if role else []))})" if same or role else ""
        raise OutputError(f"{path}: is an input of this command{what}: refusing to write over it; choose "
                          "another output name")
