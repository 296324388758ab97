"""The one TOML reader of every input file (recordings, problems, datasheets, sheets, schemes)."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from .errors import InputError


def read_toml(path: str | Path, what: str) -> dict:
    """Read a TOML file as a dictionary (see :func:`read_toml_text`)."""
    return read_toml_text(path, what)[0]


def array_table_lines(text: str, name: str) -> list[int]:
    """1-based line numbers of the headers ``[[name]]`` in a TOML text, in order."""
    pattern = re.compile(rf"^\s*\[\[\s*{re.escape(name)}\s*\]\]", re.MULTILINE)
    return [text.count("\n", 0, m.start()) + 1 for m in pattern.finditer(text)]


def read_toml_text(path: str | Path, what: str) -> tuple[dict, str]:
    """Read a TOML file: its dictionary and its text.

    Parameters
    ----------
    path : str or Path
    what : str
        What the file should be, for the messages ("recording description", "problem file", ...).

    Raises
    ------
    InputError
        Naming the file (and the line) of a missing, unreadable, non-UTF-8 or invalid file.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(path, f"is a folder, not a {what}")
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError(path, f"no such {what}") from None
    except OSError as exc:
        raise InputError(path, f"cannot be read ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise InputError(path, f"not UTF-8 text (byte {raw[exc.start]:#04x})", line=line) from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise InputError(path, f"not valid TOML for a {what}: {exc}") from None
