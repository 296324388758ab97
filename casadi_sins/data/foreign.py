"""Other tools' files as named numeric arrays, read a block of rows at a time (the importers' readers).

Each reader opens one kind of file and answers two questions without reading the data: which arrays it
holds by name, and the shape each declares (:meth:`Source.shape`); then it yields the rows asked for, a
block at a time (:meth:`Source.blocks`), so that a file declaring far more rows than it holds (a few
kilobytes of HDF5 declaring 3e8 rows, a Parquet file of 1e9 identical rows) is judged on its first block
instead of being expanded into memory.  What is not an array of real numbers (text, cells, structs,
compound or complex values, null shapes), an HDF5 link leaving the file (external links, external
storage, virtual datasets) or going round in a loop, and a library's own failure are one
:class:`~core.errors.InputError` naming the file and the array.

The libraries are well-kept optional extras: SciPy's ``loadmat`` (``mat``), h5py (``hdf5``), pyarrow
(``parquet``); a missing one is a one-line error naming the extra.
"""

from __future__ import annotations

import contextlib
import importlib
from pathlib import Path
from typing import Iterator

import numpy as np

from ..core.errors import InputError
from ..core.extras import missing_extra

#: The extra to install for each reader (``pip install "casadi-sins[EXTRA]"``, :func:`core.extras.missing_extra`).
EXTRAS = {"scipy.io": "mat", "h5py": "hdf5", "pyarrow.parquet": "parquet"}
#: What a MATLAB class is, for the messages about arrays that are not numbers.
MAT_WORDS = {"char": "text", "cell": "a cell array", "struct": "a struct", "object": "an object",
             "sparse": "a sparse matrix", "function_handle": "a function handle", "opaque": "an opaque object"}
#: The MATLAB classes of real numbers.
MAT_NUMERIC = {"double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
               "logical"}
#: Soft links followed one after the other before an HDF5 path is taken for a loop.
MAX_LINKS = 16
#: The largest HDF5 chunk read (bytes): a few kB of zeros compressed into one chunk of 2 GB would otherwise be
#: decompressed whole to read its first row (HDF5's own writers chunk by kB to MB).
MAX_CHUNK_BYTES = 64e6


def module(name: str):
    """An optional reader, or a one-line error naming the extra that brings it."""
    try:
        return importlib.import_module(name)
    except ImportError:
        raise InputError(None, missing_extra("reading this format", EXTRAS[name], name.split(".")[0])) from None


def dtype_fault(dtype: np.dtype) -> str | None:
    """Why an array of ``dtype`` is not one of real numbers (None when it is)."""
    kind = np.dtype(dtype).kind
    if kind in "biuf":
        return None
    return {"c": "complex numbers (the imaginary part would be lost)", "S": "text", "U": "text", "O":
            "objects (text, cells or references)", "V": "records of several fields (a compound type)",
            "M": "dates", "m": "time spans"}.get(kind, f"values of type {dtype}")


def sample_axis(shape: tuple, columns: int) -> int | None:
    """The axis along which an array of ``shape`` holds its samples: a vector ``(N,)``, ``(N, 1)``, ``(1, N)``
    (``columns`` 1) or three columns ``(N, 3)`` or rows ``(3, N)`` (``columns`` 3); None for another shape."""
    if len(shape) == 1:
        return 0 if columns == 1 else None
    if len(shape) != 2:
        return None
    if shape[1] == columns:
        return 0
    if shape[0] == columns:
        return 1
    return None


class Source:
    """Named arrays of one file (subclasses: one per format)."""

    def __init__(self, path: Path):
        self.path = path

    def shape(self, name: str) -> tuple | None:
        """The declared shape of the array ``name`` (None: no such array); refuses what is not one of real
        numbers."""
        raise NotImplementedError

    def slice(self, name: str, axis: int, start: int, stop: int) -> np.ndarray:
        """Rows ``start:stop`` of ``name`` along its sample ``axis`` (samples first in the result)."""
        raise NotImplementedError

    def blocks(self, names: dict[str, int], rows: int, block: int) -> Iterator[tuple[int, dict]]:
        """``(first row, {name: rows of the block})`` for ``rows`` samples, ``block`` rows at a time; ``names``
        maps each array to its sample axis."""
        for start in range(0, rows, block):
            stop = min(start + block, rows)
            yield start, {name: self.slice(name, axis, start, stop) for name, axis in names.items()}


class ArraySource(Source):
    """Arrays already in memory (a ``.mat`` file, a PSINS text table)."""

    def __init__(self, path: Path, arrays: dict):
        super().__init__(path)
        self.arrays = arrays

    def shape(self, name):
        value = self.arrays.get(name)
        return None if value is None else value.shape

    def slice(self, name, axis, start, stop):
        value = self.arrays[name]
        part = value[start:stop] if axis == 0 else value[:, start:stop].T
        return part


def mat_source(path: Path, wanted) -> ArraySource:
    """The numeric variables of a MATLAB ``.mat`` file among ``wanted``; their classes and shapes are read
    first (``whosmat``), so text, cells and structs are named without loading them and the declared size is
    judged before anything is allocated (:func:`check_declared`)."""
    io = module("scipy.io")
    try:
        listing = {name: (tuple(shape), kind) for name, shape, kind in io.whosmat(path)}
    except Exception as exc:  # noqa: BLE001 (SciPy raises several types on a file it cannot read)
        raise InputError(path, f"not a MATLAB .mat file SciPy reads (v7.3 files are HDF5: import hdf5) "
                         f"({type(exc).__name__}: {exc})") from None
    names = [n for n in dict.fromkeys(wanted) if n in listing]
    for name in names:
        shape, kind = listing[name]
        if kind not in MAT_NUMERIC:
            raise InputError(path, f"variable {name!r} holds {MAT_WORDS.get(kind, kind)}, not an array of numbers")
        if 0 in shape:
            raise InputError(path, f"variable {name!r} is empty (shape {'x'.join(map(str, shape))})")
    check_declared(path, sum(int(np.prod(listing[n][0], dtype=float)) for n in names), streamed=False)
    if not names:
        return ArraySource(path, {})
    try:
        data = io.loadmat(path, variable_names=names)
    except MemoryError:
        raise InputError(path, "not enough memory to read it") from None
    except Exception as exc:  # noqa: BLE001
        raise InputError(path, f"cannot be read as a MATLAB .mat file ({type(exc).__name__}: {exc})") from None
    arrays = {}
    for name in names:
        value = np.asarray(data[name])
        fault = dtype_fault(value.dtype)
        if fault:
            raise InputError(path, f"variable {name!r} holds {fault}, not an array of real numbers")
        arrays[name] = value
    return ArraySource(path, arrays)


def text_table(path: Path) -> np.ndarray:
    """A text table of numbers (``.csv`` comma-separated, otherwise whitespace), as floats."""
    try:
        return np.loadtxt(path, delimiter="," if path.suffix.lower() == ".csv" else None, ndmin=2)
    except MemoryError:
        raise InputError(path, "not enough memory to read it") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(path, f"not a text table of numbers ({exc})") from None


class Hdf5Source(Source):
    """Datasets of an HDF5 file by path; links are checked before they are followed (never out of the file)."""

    def __init__(self, path: Path, handle):
        super().__init__(path)
        self.handle = handle
        self.h5py = module("h5py")
        self._datasets: dict = {}

    def _resolve(self, name: str):
        """The dataset at ``name`` (None: nothing there), after checking every link on the way."""
        h5py = self.h5py
        where, hops = name.strip("/"), 0
        parts = [p for p in where.split("/") if p]
        if not parts:
            return None
        done: list[str] = []
        while parts:
            part = parts.pop(0)
            here = "/" + "/".join(done + [part])
            try:
                link = self.handle.get(here, getlink=True)
            except (KeyError, RuntimeError, OSError, ValueError) as exc:
                raise InputError(self.path, f"{name!r} cannot be followed ({exc})") from None
            if link is None:
                return None
            if isinstance(link, h5py.ExternalLink):
                raise InputError(self.path, f"{name!r} is a link to another file ({link.filename}): external links "
                                 "are not followed; copy the data into this file")
            if isinstance(link, h5py.SoftLink):
                hops += 1
                if hops > MAX_LINKS:
                    raise InputError(self.path, f"{name!r}: links go round in a loop (more than {MAX_LINKS} in a row)")
                target = link.path if link.path.startswith("/") else "/".join(["", *done, link.path])
                parts = [p for p in target.split("/") if p] + parts
                done = []
                continue
            done.append(part)
        try:
            item = self.handle["/" + "/".join(done)]
        except (KeyError, RuntimeError, OSError, ValueError) as exc:
            raise InputError(self.path, f"{name!r} cannot be read ({exc})") from None
        return item

    def dataset(self, name: str):
        """The checked dataset ``name`` (None: none there)."""
        if name in self._datasets:
            return self._datasets[name]
        item = self._resolve(name)
        if item is not None:
            if not isinstance(item, self.h5py.Dataset):
                raise InputError(self.path, f"{name!r} is a group, not a dataset (name one of its datasets: "
                                 f"{_members(item)})")
            if item.shape is None:
                raise InputError(self.path, f"{name!r} holds no data (a null dataspace)")
            if item.is_virtual or item.external:
                raise InputError(self.path, f"{name!r} keeps its data in other files (a virtual dataset or external "
                                 "storage): not followed; copy the data into this file")
            fault = dtype_fault(item.dtype)
            if fault:
                raise InputError(self.path, f"{name!r} holds {fault}, not an array of real numbers")
            if not item.shape or 0 in item.shape:
                raise InputError(self.path, f"{name!r} has shape {item.shape}: no samples")
            chunk = float(np.prod(item.chunks or (1,), dtype=float)) * item.dtype.itemsize
            if chunk > MAX_CHUNK_BYTES:
                raise InputError(self.path, f"{name!r} is stored in chunks of {chunk / 1e6:.3g} MB: reading any row "
                                 f"would decompress a whole chunk (at most {MAX_CHUNK_BYTES / 1e6:g} MB); rewrite it "
                                 "with smaller chunks")
        self._datasets[name] = item
        return item

    def shape(self, name):
        item = self.dataset(name)
        return None if item is None else tuple(item.shape)

    def slice(self, name, axis, start, stop):
        item = self.dataset(name)
        try:
            return item[start:stop] if axis == 0 else np.asarray(item[:, start:stop]).T
        except (OSError, RuntimeError, ValueError, TypeError) as exc:  # a corrupt chunk, a failing filter
            raise InputError(self.path, f"{name!r}: rows {start + 1}-{stop} cannot be read ({exc})") from None


def _members(group) -> str:
    names = list(group.keys())[:6]
    return ", ".join(repr(n) for n in names) + (" ..." if len(group) > 6 else "") if names else "it is empty"


@contextlib.contextmanager
def hdf5_source(path: Path):
    """An :class:`Hdf5Source` on an open file."""
    h5py = module("h5py")
    try:
        handle = h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        raise InputError(path, f"not an HDF5 file ({exc})") from None
    with handle:
        yield Hdf5Source(path, handle)


class ParquetSource(Source):
    """Columns of a Parquet table by name; rows decoded a batch at a time."""

    def __init__(self, path: Path):
        super().__init__(path)
        pq = module("pyarrow.parquet")
        self.pa = module("pyarrow")
        try:
            self.file = pq.ParquetFile(path)
            schema = self.file.schema_arrow
            self.rows = int(self.file.metadata.num_rows)
        except MemoryError:
            raise InputError(path, "not enough memory to read its footer") from None
        except Exception as exc:  # noqa: BLE001 (pyarrow raises its own error types)
            raise InputError(path, f"not a Parquet file ({type(exc).__name__}: {exc})") from None
        self.types = {field.name: field.type for field in schema}

    def shape(self, name):
        kind = self.types.get(name)
        if kind is None:
            return None
        types = self.pa.types
        if not (types.is_integer(kind) or types.is_floating(kind) or types.is_boolean(kind)):
            raise InputError(self.path, f"column {name!r} holds {kind}, not numbers")
        return (self.rows,)

    def blocks(self, names, rows, block):
        start = 0
        try:
            for batch in self.file.iter_batches(batch_size=block, columns=list(names)):
                yield start, {name: batch.column(name).to_numpy(zero_copy_only=False).astype(float, copy=False)
                              for name in names}
                start += batch.num_rows
        except MemoryError:
            raise InputError(self.path, f"not enough memory to read rows from {start + 1}") from None
        except InputError:
            raise
        except Exception as exc:  # noqa: BLE001
            raise InputError(self.path, f"rows from {start + 1} cannot be read ({type(exc).__name__}: {exc})") from None


def check_declared(path: Path, values: float, streamed: bool, columns_memory: float = 4.0) -> None:
    """Refuse a file whose arrays declare more values than memory holds, before any is read; a file read whole
    (not ``streamed``: a ``.mat``) also when it declares far more than it could hold (a compression bomb).

    ``values`` is the count of numbers to be read; each needs 8 bytes, ``columns_memory`` times over while a
    recording is assembled, checked and written.
    """
    from ..core.inputs import memory_available

    need = values * 8.0 * columns_memory
    free = memory_available()
    if need > free:
        raise InputError(path, f"declares {values:.3g} numbers: about {need / 1e9:.3g} GB of memory to import, "
                         f"{max(free, 0.0) / 1e9:.3g} GB available")
    size = path.stat().st_size
    if not streamed and values * 8.0 > max(COMPRESSION_LIMIT * size, UNCHECKED_BYTES):
        raise InputError(path, f"declares {values:.3g} numbers ({values * 8 / 1e9:.3g} GB) in {size / 1e6:.3g} MB: "
                         f"more than {COMPRESSION_LIMIT:g} times its size, not samples of a sensor (a compression "
                         "bomb?)")


#: A file read whole may expand this many times (zlib on sensor samples gives a few times at most) ...
COMPRESSION_LIMIT = 20.0
#: ... unless it declares less than this, in bytes.
UNCHECKED_BYTES = 256e6
