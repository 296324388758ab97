"""The rotation schemes and error sheets shipped with the package, found by name.

They are package data of ``casadi_sins.problems``: sheets as ``NAME.toml`` beside the problem files,
schemes as ``schemes/NAME.toml``.  A command-line argument is a file when it names one (or has a
suffix or a folder in it), otherwise the name of a shipped file.
"""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path

from ...core.errors import InputError, shown
from ...core.toml import read_toml_text

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")


def shipped_folder() -> Path:
    """The folder of the shipped problem files (the package ``casadi_sins.problems``)."""
    return Path(str(resources.files("casadi_sins.problems")))


def shipped_names(kind: str) -> list[str]:
    """Names of the shipped files of one kind: ``"schemes"`` or ``"sheets"`` (error sheets)."""
    if kind == "schemes":
        return sorted(p.stem for p in (shipped_folder() / "schemes").glob("*.toml"))
    return sorted(p.stem for p in shipped_folder().glob("*.toml") if _is_sheet(p))


def _is_sheet(path: Path) -> bool:
    """Whether a shipped TOML file is an error sheet (by its format line, without parsing it all)."""
    try:
        return 'format = "casadi-sins-errors/1"' in path.read_text(encoding="utf-8")
    except OSError:
        return False


def find_file(name_or_path, kind: str, what: str) -> tuple[Path, bool]:
    """The file a user named: ``(path, shipped)``.

    Parameters
    ----------
    name_or_path : str or Path
        A file, or the name of a shipped file (letters, digits, ``-``, ``_``, ``.``; no suffix).
    kind : str
        ``"schemes"`` or ``"sheets"``.
    what : str
        What the file is, for the message ("scheme", "error sheet").

    Raises
    ------
    InputError
        When it is neither an existing file nor a shipped name (the message lists the shipped ones).
    """
    path = Path(name_or_path)
    text = str(name_or_path)
    if path.exists() or path.is_symlink() or path.suffix or not _NAME.fullmatch(text):
        return path, False
    folder = shipped_folder() / "schemes" if kind == "schemes" else shipped_folder()
    candidate = folder / f"{text}.toml"
    if candidate.is_file() and text in shipped_names(kind):
        return candidate, True
    raise InputError(text, f"no such {what} file or shipped {what} (shipped: {', '.join(shipped_names(kind))})")


def read_file(name_or_path, kind: str, what: str, file_format: str, label: str) -> tuple[dict, str, Path, str]:
    """A file a user named (:func:`find_file`) read as TOML, its ``format`` checked.

    Parameters
    ----------
    name_or_path, kind, what
        As :func:`find_file`.
    file_format : str
        The ``format`` key the file must have.
    label : str
        What the file is when read ("scheme file", "error sheet").

    Returns
    -------
    (dict, str, Path, str)
        Its data, its text, its path and where it came from (``NAME (shipped)`` or the path).

    Raises
    ------
    InputError
        Naming the file when it cannot be found or read or has another format.
    """
    path, is_shipped = find_file(name_or_path, kind, what)
    data, text = read_toml_text(path, label)
    if data.get("format") != file_format:
        raise InputError(path, f"format must be {file_format!r}, found {shown(data.get('format'))}")
    return data, text, path, f"{path.stem} (shipped)" if is_shipped else str(path)
