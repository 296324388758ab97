"""File output that never leaves anything half-written, a run that owns its output set, and safe output names.

Every command writes its outputs through :func:`write_files` (all together or none) or
:func:`atomic_open` (one file written in pieces), and checks the place with
:func:`check_writable` before it computes anything.  Within :func:`gathered_writes` (how the command line
runs a command) every write is only staged and all are written together when the command succeeds; every
target is checked by :func:`~casadi_sins.core.guard.check_output_target` (never an input, never a device).

A run owns its output set (:func:`claim_outputs`): every file it may write (a table and everything of its
stem: report, certificate, exports).  The files of that set it does not write again are removed in the same
all-or-nothing step that writes the others (``stale`` of :func:`write_files`), so that no file of an earlier
run outlives a rerun to contradict it; no input is ever among them
(:func:`~casadi_sins.core.guard.check_removable`).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import tempfile
from pathlib import Path

from .errors import OutputError
from .guard import check_output_target, check_removable
from .signals import signals_held

#: The writes staged by :func:`gathered_writes` (``None``: written at once).
_PENDING: dict | None = None
#: The output set claimed within :func:`gathered_writes` (:func:`claim_outputs`).
_OWNED: list | None = None


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def safe_stem(name: str) -> str:
    """A name usable as a file name inside an output folder (``../x`` or ``/x`` cannot leave it): the
    last path component, only ASCII letters, digits and ``-_.``, no leading dot, at most 120 characters.
    The one function by which any name (a recording's, a unit's, a label) becomes a path."""
    last = str(name).replace("\\", "/").split("/")[-1]
    cleaned = "".join(c if (c.isascii() and c.isalnum()) or c in "-_." else "-" for c in last)
    return cleaned.strip(".")[:120].strip(".") or "recording"


@contextlib.contextmanager
def gathered_writes():
    """Stage every write of the block and write them all together (:func:`write_files`) when it ends
    without an error, removing in the same step the files of the claimed output set (:func:`claim_outputs`)
    not written again; nothing is written or removed when it does not end well (an error, Ctrl-C, SIGTERM)."""
    global _PENDING, _OWNED
    if _PENDING is not None:  # already gathering
        yield
        return
    _PENDING, _OWNED = {}, []
    try:
        yield
        pending, owned = _PENDING, _OWNED
    finally:
        _PENDING = _OWNED = None
    if pending or owned:
        write_files(pending, stale=owned)


def claim_outputs(paths) -> list[Path]:
    """Declare files the running command owns: those it may write (its output set).  Each is checked at once,
    before any computation: never an input of the command, never a folder or a device
    (:func:`~casadi_sins.core.guard.check_output_target`).  Within :func:`gathered_writes` those the command does
    not write again are removed when its writes are committed (all together); elsewhere the caller passes them
    as ``stale`` to :func:`write_files` itself.

    Raises
    ------
    OutputError
        Naming the first path that is an input or not a regular file.
    """
    paths = [Path(p) for p in paths]
    for path in paths:
        check_output_target(path)
    if _OWNED is not None:
        _OWNED.extend(paths)
    return paths


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "wb", **options):
    """A file object on a temporary file in ``path``'s folder, renamed to ``path`` when the block ends
    without an error (and removed, with any folder made for it, when it does not).

    Raises
    ------
    OutputError
        Naming ``path`` when the file system refuses it.
    """
    path = Path(path)
    check_output_target(path)
    if _PENDING is not None:
        buffer = io.BytesIO() if "b" in mode else io.StringIO(newline="")
        yield buffer
        data = buffer.getvalue()
        _PENDING[path] = data if isinstance(data, bytes) else data.encode(options.get("encoding") or "utf-8")
        return
    made: list[Path] = []
    tmp = None
    try:
        _make_folders(path.parent, made)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, mode, **options) as handle:
            yield handle
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
        _remove_folders(made)
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):
            raise OutputError(f"{path}: cannot be written ({exc.strerror or exc})") from None
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

    A file target must not be a folder, a folder target not a file.  The place is probed by creating
    (and removing) a temporary file in the target's own folder, or in its nearest existing ancestor when
    the folder is still to be made: permissions, read-only and full file systems show there.

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
        check_output_target(path)
        folder = path.parent
    probe = folder
    while not probe.exists():  # the first existing ancestor must let us create the rest
        if probe == probe.parent:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{path}: {probe} is a file, not a folder")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".casadi-sins-probe.", dir=probe)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write in {probe} ({exc.strerror or exc})") from None
    return path


def _make_folders(folder: Path, made: list[Path]) -> None:
    """Create ``folder`` and its missing parents, remembering each one made (to remove them on failure)."""
    missing = []
    probe = folder
    while not probe.exists():
        missing.append(probe)
        probe = probe.parent
    for item in reversed(missing):
        try:
            item.mkdir()
        except FileExistsError:  # another process made it meanwhile: fine if it is a folder
            if not item.is_dir():
                raise
            continue
        made.append(item)


def _remove_folders(made: list[Path]) -> None:
    for item in reversed(made):
        try:
            item.rmdir()  # only when still empty
        except OSError:
            pass


def write_files(files: dict, stale=()) -> list[Path]:
    """Write several files as one: all are staged as temporary files first and renamed only when every
    one was written, so that a failure (a full disk, a signal) leaves none of them, no temporary and no
    folder made for them behind.  The files of ``stale`` that are not written now (an earlier run's) are
    removed in the same step: set aside first, deleted once every rename succeeded, put back otherwise.

    Parameters
    ----------
    files : dict of Path -> bytes or callable
        The content, or a function that writes it into a binary file object (large files, in chunks).
    stale : iterable of Path
        Files of the run's output set (:func:`claim_outputs`): those not in ``files`` are removed.  Each is
        checked first: never an input, never a folder or a device.

    Raises
    ------
    OutputError
        Naming the file that could not be written, or a stale file that is an input.
    """
    for path in files:
        check_output_target(path)
    written = {os.path.abspath(path) for path in files}
    if _PENDING is not None:
        _PENDING.update({Path(path): data for path, data in files.items()})
        _OWNED.extend(Path(path) for path in stale)
        return [Path(path) for path in files]
    unique = {os.path.abspath(path): Path(path) for path in stale}  # as named, once each
    stale = [path for key, path in unique.items() if key not in written and check_removable(path)]
    staged: list[tuple[str, Path]] = []
    made: list[Path] = []
    aside: list[tuple[str, Path]] = []
    current = None
    try:
        for path, data in files.items():
            current = path = Path(path)
            _make_folders(path.parent, made)
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            staged.append((tmp, path))
            with os.fdopen(fd, "wb") as handle:
                if callable(data):
                    data(handle)
                else:
                    handle.write(data)
            os.chmod(tmp, 0o666 & ~_umask())
        with signals_held():  # the renames are one step: a signal waits until they are done
            for path in stale:
                current = path
                tmp = _aside_name(path)
                try:
                    os.rename(path, tmp)
                except OSError:
                    os.unlink(tmp)
                    raise
                aside.append((tmp, path))
            for tmp, path in staged:
                current = path
                os.replace(tmp, path)
            for tmp, _ in aside:  # done: the earlier run's files go (before any held signal is let through)
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
    except BaseException as exc:
        for tmp, _ in staged:
            if os.path.exists(tmp):
                os.unlink(tmp)
        for tmp, path in aside:  # an earlier run's files come back
            if os.path.lexists(tmp):
                os.replace(tmp, path)
        _remove_folders(made)
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):
            raise OutputError(f"{current}: cannot be written ({exc.strerror or exc})") from None
        raise
    return [path for _, path in staged]


def _aside_name(path: Path) -> str:
    """A free temporary name beside ``path`` to set it aside under."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".old", dir=path.parent)
    os.close(fd)
    return tmp


def file_sha256(path: str | Path, cancelled=None) -> str | None:
    """SHA-256 of a file's bytes (None when ``cancelled()`` turns true on the way: a hash in the background)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            if cancelled is not None and cancelled():
                return None
            digest.update(block)
    return digest.hexdigest()
