"""File output that never leaves anything half-written, and safe output names.

Every command writes its outputs through :func:`write_files` (all together or none) or
:func:`atomic_open` (one file written in pieces), and checks the place with
:func:`check_writable` before it computes anything.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from .errors import OutputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def safe_stem(name: str) -> str:
    """A name usable as a file name inside an output folder (``../x`` or ``/x`` cannot leave it)."""
    cleaned = "".join(c if c.isalnum() or c in "-_." else "-" for c in str(name).replace("\\", "/").split("/")[-1])
    return cleaned.strip(".")[:120] or "recording"


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "wb", **options):
    """A file object on a temporary file in ``path``'s folder, renamed to ``path`` when the block ends
    without an error (and removed when it does not)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, mode, **options) as handle:
            yield handle
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder and rename it."""
    with atomic_open(path, "wb") as handle:
        handle.write(data)
    return Path(path)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def check_writable(path: str | Path, directory: bool = False) -> Path:
    """Fail early (before any computation) when ``path`` cannot be written.

    A file target must not be a folder and its folder must be creatable and writable; a folder target
    must not be a file.

    Raises
    ------
    OutputError
        Naming ``path``.
    """
    path = Path(path)
    if directory:
        if path.exists() and not path.is_dir():
            raise OutputError(f"{path}: exists and is not a folder")
        folder = path
    else:
        if path.is_dir():
            raise OutputError(f"{path}: is a folder, not a file to write")
        folder = path.parent
    probe = folder
    while not probe.exists():  # the first existing ancestor must let us create the rest
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{path}: {probe} is a file, not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"{path}: {probe} is not writable")
    return path


def write_files(files: dict) -> list[Path]:
    """Write several files as one: all are staged as temporary files first and renamed only when every
    one was written, so that a failure leaves none of them (and no temporary) behind.

    Parameters
    ----------
    files : dict of Path -> bytes
    """
    staged: list[tuple[str, Path]] = []
    try:
        for path, data in files.items():
            path = Path(path)
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            staged.append((tmp, path))
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
            os.chmod(tmp, 0o666 & ~_umask())
        for tmp, path in staged:
            os.replace(tmp, path)
    except BaseException:
        for tmp, _ in staged:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise
    return [path for _, path in staged]
