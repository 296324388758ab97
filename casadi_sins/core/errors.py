"""The errors a user sees: one line naming the file (and line, column) at fault."""

from __future__ import annotations

from pathlib import Path


def shown(value, limit: int = 60) -> str:
    """A value as it may appear in a one-line message: plain numbers, long texts cut short."""
    if isinstance(value, float) or type(value).__name__.startswith("float"):
        return f"{float(value):.10g}"
    text = repr(value) if isinstance(value, str) else str(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class InputError(ValueError):
    """An input (recording, table, problem file, datasheet, ...) that cannot be used.

    Parameters
    ----------
    path : str or Path or None
        The file at fault, as the user named it.
    message : str
        What is wrong.
    line, column : int or str, optional
        Where in the file (1-based line; column by name or number).

    Notes
    -----
    The string is ``"PATH, line L, column C: message"``.
    """

    def __init__(self, path, message: str, line: int | None = None, column=None):
        self.path = None if path is None else Path(path)
        self.line = line
        self.column = column
        self.reason = message
        where = [str(path)] if path is not None else []
        if line is not None:
            where.append(f"line {line}")
        if column is not None:
            where.append(f"column {column}")
        super().__init__(f"{', '.join(where)}: {message}" if where else message)


class OutputError(OSError):
    """An output location that cannot be written; the message names it."""


class Caution(UserWarning):
    """A warning of ours for the user (``warnings.warn(..., Caution)``): the command line prints it as one line
    ``warning: ...``; the libraries' own warnings are silenced there."""
