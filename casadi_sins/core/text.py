"""Text from the outside (names, unit ids, command lines) made safe for every format we write.

A recording's name or a unit id may hold anything: a newline would become a line of MATLAB in an
export or a raw line in a Markdown report.  Every text format written goes through these.
"""

from __future__ import annotations

import re

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]+")


def one_line(text, limit: int = 200) -> str:
    """``text`` as one printable line: control characters (newlines included) become a space, long texts
    are cut with an ellipsis."""
    line = _CONTROL.sub(" ", str(text)).strip()
    return line if len(line) <= limit else line[: limit - 3] + "..."


def markdown_text(text, limit: int = 2000) -> str:
    """``text`` as inline Markdown that cannot break a table or start a block: one line, ``|``, ``<`` and
    backticks escaped."""
    return (one_line(text, limit).replace("\\", "\\\\").replace("|", "\\|").replace("`", "\\`")
            .replace("[", "\\[").replace("]", "\\]").replace("<", "&lt;").replace(">", "&gt;"))


def code_comment(text, limit: int = 200) -> str:
    """``text`` for a one-line comment of MATLAB, C or TOML: one line, no comment terminators."""
    return (one_line(text, limit).replace("*/", "* /").replace("/*", "/ *").replace("%{", "% {")
            .replace("%}", "% }"))


#: Spreadsheets run a cell that starts with one of these as a formula.
FORMULA_PREFIXES = ("=", "+", "-", "@", "\t", "\r")


def spreadsheet_cell(text) -> str:
    """A name for a CSV cell that no spreadsheet runs as a formula (OWASP: a leading apostrophe)."""
    text = str(text)
    return "'" + text if text.startswith(FORMULA_PREFIXES) else text


#: An ASCII decimal number: no digit groups (``1_000``), no other scripts' digits (``١٢٣``, ``１２３``).
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def decimal_number(text) -> float:
    """The value of a numeric field: only ASCII decimal numbers (surrounding blanks allowed).

    Raises
    ------
    ValueError
        For anything else (``1_000``, ``١٢٣``, ``１２３``, ``0x10``, ``inf``, ``nan``, empty).
    """
    field = str(text).strip(" \t")
    if not _DECIMAL.fullmatch(field):
        raise ValueError(f"not an ASCII decimal number: {field!r}")
    return float(field)


def plural(count: int, word: str) -> str:
    """``"1 group"``, ``"3 groups"``."""
    return f"{count} {word}{'' if count == 1 else 's'}"
