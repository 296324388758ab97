"""The one TOML reader of every input file (recordings, problems, datasheets, sheets, schemes)."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from .errors import InputError
from .inputs import check_input_file

#: Every TOML input of the project (descriptions, problems, datasheets, sheets, schemes) is small.
MAX_TOML_BYTES = 4_000_000
#: Deepest nesting of tables and arrays any of them needs.
MAX_DEPTH = 8


def read_toml(path: str | Path, what: str) -> dict:
    """Read a TOML file as a dictionary (see :func:`read_toml_text`)."""
    return read_toml_text(path, what)[0]


def array_table_lines(text: str, name: str) -> list[int]:
    """1-based line numbers of the headers ``[[name]]`` in a TOML text, in order."""
    pattern = re.compile(rf"^[ \t]*\[\[[ \t]*{re.escape(name)}[ \t]*\]\]", re.MULTILINE)  # not across lines
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
    check_input_file(path, what, MAX_TOML_BYTES)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(path, f"cannot be read ({exc.strerror or exc})") from None
    return toml_from_bytes(raw, path, what)


def toml_from_bytes(raw: bytes, path: str | Path, what: str) -> tuple[dict, str]:
    """The dictionary and text of TOML bytes, checked as :func:`read_toml_text` checks a file (``path``
    names them in messages)."""
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise InputError(path, f"not UTF-8 text (byte {raw[exc.start]:#04x})", line=line) from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(path, f"not valid TOML for a {what}: {exc}") from None
    except RecursionError:
        raise InputError(path, f"nested too deeply for a {what}") from None
    if _depth(doc) > MAX_DEPTH:
        raise InputError(path, f"nested more than {MAX_DEPTH} levels deep: not a {what}")
    _check_plain_numbers(path, text)
    return doc, text


_STRINGS = re.compile(r'"(?:[^"\\]|\\.)*"|\'[^\']*\'')
#: A TOML number that is not plain decimal: digit groups (1_000) or hexadecimal, octal, binary.
_NOT_DECIMAL = re.compile(r"(?<![\w.+-])[+-]?(?:[0-9]+(?:_[0-9]+)+|0[xob][0-9A-Fa-f_]+)(?![\w])")


def _check_plain_numbers(path: Path, text: str) -> None:
    """Only ASCII decimal numbers in values (TOML also reads ``1_000`` and ``0x10``; no other format does)."""
    for number, line in enumerate(text.splitlines(), start=1):
        value = _STRINGS.sub('""', line).split("#", 1)[0]
        if "=" in value and not value.lstrip().startswith("["):
            value = value.split("=", 1)[1]
        found = _NOT_DECIMAL.search(value)
        if found:
            raise InputError(path, f"{found.group(0)!r} is not a plain decimal number (write it without '_' "
                             "or a base prefix)", line=number)


def _depth(value, level: int = 0) -> int:
    """Nesting depth of tables and arrays (stops counting past the limit)."""
    if level > MAX_DEPTH:
        return level
    if isinstance(value, dict):
        return max((_depth(v, level + 1) for v in value.values()), default=level + 1)
    if isinstance(value, list):
        return max((_depth(v, level + 1) for v in value), default=level + 1)
    return level
