"""The input files a command line names: every argument that is an existing file, and the CSV of
samples each recording description among them points to (so that no output lands on either)."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from .registry import command

#: A description is a few kilobytes; larger TOML files are not looked into here.
MAX_LOOK_BYTES = 4_000_000


def command_inputs(args) -> list:
    """Every existing file named by ``args`` (its command's arguments that are no inputs excepted:
    :meth:`cli.command.Command.is_input`), and the ``data`` file of each TOML among them (a recording
    description's CSV, relative to the description, as ``(path, role)``)."""
    record = command(args.command)
    found: list = []
    for key, value in vars(args).items():
        if not record.is_input(key):
            continue
        for item in value if isinstance(value, (list, tuple)) else [value]:
            if isinstance(item, (str, Path)) and str(item) and _is_file(item):
                found.extend(recording_inputs(item))
    return found


def recording_inputs(path) -> list:
    """A file and, when it is a recording description, the data file it names (as ``(path, role)``); nothing is
    read from anything but a regular file (a FIFO named ``x.toml`` would never end)."""
    return [str(path), *(_described_data(Path(path)) if _is_file(path) else [])]


def _is_file(path) -> bool:
    try:
        return os.path.isfile(path)
    except (OSError, ValueError):
        return False


def _described_data(path: Path) -> list[tuple[str, str]]:
    """The ``data`` file a TOML description names, when it is one (else nothing; its reader judges it)."""
    if path.suffix.lower() != ".toml":
        return []
    try:
        if os.path.getsize(path) > MAX_LOOK_BYTES:
            return []
        doc = tomllib.loads(path.read_bytes().decode("utf-8"))
    except (OSError, ValueError, UnicodeDecodeError, RecursionError):
        return []
    data = doc.get("data")
    return [(str(path.parent / data), f"the samples of {path}")] if isinstance(data, str) and data.strip() else []
