"""Input files read safely: only regular files, sized against the memory available, opened as text.

A FIFO, a device (``/dev/zero``), a folder, a symlink loop or a dangling link are named and refused
before anything is read; a file larger than the memory it would need is refused before reading;
compressed files (``.gz``, ``.bz2``, ``.xz``, ``.zip``) are opened as such.  Every file checked here is
an input of the running command (:func:`core.guard.register_input`): no output lands on it.
"""

from __future__ import annotations

import bz2
import gzip
import io
import lzma
import os
import resource
import stat
import zipfile
from pathlib import Path

from .errors import InputError
from .guard import register_input

#: Typical growth of a CSV of pulses in memory while it is parsed (text -> float64 columns and copies).
CSV_MEMORY_FACTOR = 3.0
#: Typical compression ratio of a CSV of pulses (to size compressed files before reading).
COMPRESSION_RATIO = 8.0
COMPRESSED = (".gz", ".bz2", ".xz", ".zip")


def check_input_file(path: str | Path, what: str, max_bytes: int | None = None) -> int:
    """Refuse anything but a readable regular file; return its size in bytes.  The file becomes an input of
    the running command (:mod:`core.guard`): nothing is written over it or removed.

    Raises
    ------
    InputError
        Naming ``path`` as given (not the target of a link): missing, a folder, not a regular file
        (FIFO, device, socket), a link loop, unreadable, or larger than ``max_bytes``.
    """
    path = Path(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        dangling = os.path.islink(path)
        raise InputError(path, f"no such {what}" + (" (a link to a missing file)" if dangling else "")) from None
    except OSError as exc:
        raise InputError(path, f"cannot be read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(info.st_mode):
        raise InputError(path, f"is a folder, not a {what}")
    if not stat.S_ISREG(info.st_mode):
        raise InputError(path, f"is not a regular file (a pipe, device or socket), not a {what}")
    if not os.access(path, os.R_OK):
        raise InputError(path, "is not readable (permission denied)")
    register_input(path, f"read as a {what.split(' (')[0]}")
    if max_bytes is not None and info.st_size > max_bytes:
        raise InputError(path, f"is {info.st_size / 1e6:.3g} MB, more than a {what} can be "
                         f"({max_bytes / 1e6:.3g} MB)")
    return info.st_size


def memory_available() -> float:
    """Bytes this process may still allocate: the smaller of the free memory and its address-space limit."""
    free = float("inf")
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    free = float(line.split()[1]) * 1024.0
    except OSError:
        pass
    limit, _ = resource.getrlimit(resource.RLIMIT_AS)
    if limit != resource.RLIM_INFINITY:
        try:
            with open("/proc/self/statm", encoding="ascii") as handle:
                used = float(handle.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError):
            used = 0.0
        free = min(free, limit - used)
    return free


def check_memory_for(path: str | Path, size: int, factor: float = CSV_MEMORY_FACTOR) -> None:
    """Refuse a file whose reading would need more memory than is available (naming both)."""
    expanded = size * (COMPRESSION_RATIO if Path(path).suffix in COMPRESSED else 1.0)
    need = expanded * factor
    free = memory_available()
    if need > free:
        raise InputError(path, f"reading it needs about {need / 1e9:.3g} GB of memory, {max(free, 0) / 1e9:.3g} GB "
                         "are available")


def open_binary(path: str | Path):
    """A binary file object over the file's (decompressed) content."""
    path = Path(path)
    suffix = path.suffix
    if suffix == ".gz":
        return gzip.open(path, "rb")
    if suffix == ".bz2":
        return bz2.open(path, "rb")
    if suffix == ".xz":
        return lzma.open(path, "rb")
    if suffix == ".zip":
        archive = zipfile.ZipFile(path)
        names = archive.namelist()
        if len(names) != 1:
            raise InputError(path, f"a .zip must hold exactly one CSV, it holds {len(names)} files")
        return archive.open(names[0])
    return open(path, "rb")


def first_line(path: str | Path, limit: int = 1 << 20, opener=None) -> str:
    """The first line of a (possibly compressed) text file, at most ``limit`` bytes, decoded as UTF-8
    (``opener``: a function returning the binary file object to read instead, ``path`` naming it)."""
    with (opener or (lambda: open_binary(path)))() as handle:
        raw = handle.readline(limit)
    if len(raw) >= limit and not raw.endswith(b"\n"):
        raise InputError(path, f"the first line is longer than {limit} bytes: not a CSV header", line=1)
    try:
        return raw.decode("utf-8").rstrip("\r\n")
    except UnicodeDecodeError as exc:
        raise InputError(path, f"not UTF-8 text (byte {raw[exc.start]:#04x})", line=1) from None


def decompression_errors() -> tuple[type[BaseException], ...]:
    """What a truncated or corrupt compressed file raises while it is read."""
    return (EOFError, gzip.BadGzipFile, lzma.LZMAError, zipfile.BadZipFile, OSError, io.UnsupportedOperation)
