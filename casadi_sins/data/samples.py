"""The CSV of raw pulse increments: ``time, gyro_x..z, accel_x..z`` (extra columns are ignored).

``time`` is the end of each sample interval, strictly increasing at the uniform rate ``rate_hz``;
pulses may be floats or integers.  ``.gz``, ``.bz2``, ``.xz`` and ``.zip`` files are read as such.
"""

from __future__ import annotations

import contextlib
import csv
import functools
import math
import io
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.errors import InputError, shown
from ..core.inputs import (check_input_file, check_memory_for, decompression_errors, first_line, memory_available,
                           open_binary)
from ..core.text import decimal_number
from .recording import COLUMNS, PULSE_COLUMNS, TIME_TOLERANCE

#: The optional column of the unit's temperature, degC.
TEMPERATURE_COLUMN = "temperature"
#: The optional columns of an external attitude reference (a master INS on the base, a turntable's encoders turned
#: into the table top's attitude): roll, pitch, heading in degrees, Z-Y-X Euler angles from north-east-down.
REFERENCE_COLUMNS = ("ref_roll_deg", "ref_pitch_deg", "ref_heading_deg")

#: More columns than this is not a CSV of samples (the format has 7; extra columns are allowed).
MAX_COLUMNS = 1000


#: Bytes of text parsed at a time: memory is the final arrays plus about this much.
BLOCK_BYTES = 8 << 20
#: No row of samples is longer (1000 columns of long numbers fit); a longer one is not a CSV of samples.
MAX_LINE_BYTES = 1 << 20
#: No pulse count or increment is larger: beyond 2**53 a float cannot even count pulses exactly.
MAX_PULSE = 2.0**53
#: How a missing or unreadable CSV is named.
DATA_FILE = "data file (the CSV of samples that 'data' must name)"


def read_samples(data_path: Path, rate_hz: float, with_temperature: bool = False, with_reference: bool = False,
                 source=None) -> tuple:
    """Time and pulses of the CSV (``.gz``, ``.bz2``, ``.xz``, ``.zip`` are read as such).

    With ``with_temperature`` a third item: the ``temperature`` column (degC), or None without one; with
    ``with_reference`` (and ``with_temperature``) a fourth: the reference attitude columns
    (:data:`REFERENCE_COLUMNS`, (N, 3) deg), or None without them (all three, or none).
    ``source`` (a function returning a binary file object) reads CSV bytes made in memory instead of the
    file, exactly as the file would be read (``data_path`` then only names them in messages).

    The file is read block by block (:data:`BLOCK_BYTES`) and every block is checked before the next is
    read: exactly the header's number of fields in each row (a comma inside a number would shift the
    columns), ASCII decimal numbers, finite, no pulse beyond :data:`MAX_PULSE`, time strictly increasing
    at the uniform rate.  Reading stops at the first bad line; the memory held is the arrays read so far
    (checked against the memory available as they grow) plus one block, so a compressed file that
    expands without bound (a bomb) is refused as it is read.

    Raises
    ------
    InputError
        Naming the file, line and column of the first problem.
    """
    if source is None:
        size = check_input_file(data_path, DATA_FILE)
        check_memory_for(data_path, size)
        source = functools.partial(open_binary, data_path)
    with _read_errors(data_path, source):
        columns = _header(data_path, source)
        wanted = COLUMNS + ((TEMPERATURE_COLUMN,) if with_temperature and TEMPERATURE_COLUMN in columns else ())
        given = [c for c in REFERENCE_COLUMNS if c in columns]
        if with_reference and given and len(given) < len(REFERENCE_COLUMNS):
            raise InputError(data_path, f"the reference attitude needs all of {', '.join(REFERENCE_COLUMNS)}; found "
                             f"only {', '.join(given)}", line=1)
        reference = with_reference and len(given) == len(REFERENCE_COLUMNS)
        wanted = wanted + (REFERENCE_COLUMNS if reference else ())
        values = _stream(data_path, columns, 1.0 / rate_hz, wanted, source)
    if len(values) < 2:
        raise InputError(data_path, "fewer than two samples")
    time, pulses = values[:, 0], values[:, 1:len(COLUMNS)]
    if not with_temperature:
        return time, pulses
    temperature = values[:, len(COLUMNS)].copy() if TEMPERATURE_COLUMN in wanted else None
    if not with_reference:
        return time, pulses, temperature
    return time, pulses, temperature, (values[:, -len(REFERENCE_COLUMNS):].copy() if reference else None)


def sample_blocks(data_path: Path, rate_hz: float):
    """Time and pulses of the CSV block by block, for a file too long to hold (``noise`` on hours of rest).

    Yields ``(time (n,), pulses (n, 6), text_bytes)`` per block of about :data:`BLOCK_BYTES` of text, each
    checked as :func:`read_samples` checks it (fields, numbers, pulses, uniform time, from one block to the
    next) before it is given out; ``text_bytes`` is the block's size as text, for progress.  Memory is one
    block whatever the file's length.

    Raises
    ------
    InputError
        Naming the file, line and column of the first problem (when the block holding it is reached).
    """
    data_path = Path(data_path)
    check_input_file(data_path, DATA_FILE)
    source = functools.partial(open_binary, data_path)
    with _read_errors(data_path, source):
        columns = _header(data_path, source)
        for _, values, text_bytes in _checked_blocks(data_path, columns, 1.0 / rate_hz, COLUMNS, source):
            yield values[:, 0], values[:, 1:len(COLUMNS)], text_bytes


@contextlib.contextmanager
def _read_errors(data_path: Path, source):
    """What goes wrong while reading the CSV, as an :class:`InputError` naming it."""
    try:
        yield
    except InputError:
        raise
    except MemoryError:
        raise InputError(data_path, "not enough memory to read it") from None
    except UnicodeDecodeError:
        _raise_encoding_error(data_path, source)
    except decompression_errors() as exc:
        raise InputError(data_path, f"cannot be read: truncated or corrupt ({exc.strerror or exc})"
                         if isinstance(exc, OSError) else f"cannot be read: truncated or corrupt ({exc})") from None


def _header(data_path: Path, source) -> list[str]:
    """The header's column names (stripped), checked for the format's columns."""
    line = first_line(data_path, opener=source)
    columns = [c.strip() for c in next(csv.reader([line]), [])]
    if len(columns) > MAX_COLUMNS:
        raise InputError(data_path, f"the header has {len(columns)} columns, more than {MAX_COLUMNS}: not a CSV of "
                         "samples", line=1)
    missing = [c for c in COLUMNS if c not in columns]
    if missing:
        raise InputError(data_path, f"missing column(s) {', '.join(missing)}; header must contain "
                         f"{','.join(COLUMNS)}", line=1)
    repeated = sorted({c for c in COLUMNS if columns.count(c) > 1})
    if repeated:
        raise InputError(data_path, f"column(s) {', '.join(repeated)} given twice", line=1)
    return columns


def _blocks(data_path: Path, source):
    """``(first line number, bytes of whole lines)`` after the header, :data:`BLOCK_BYTES` at a time."""
    with source() as handle:
        handle.readline(MAX_LINE_BYTES)
        line, carry = 2, b""
        while True:
            chunk = handle.read(BLOCK_BYTES)
            text = carry + chunk
            cut = text.rfind(b"\n") + 1 if chunk else len(text)
            whole, carry = text[:cut], text[cut:]
            if len(carry) > MAX_LINE_BYTES:
                raise InputError(data_path, f"a line longer than {MAX_LINE_BYTES} bytes: not a CSV of samples",
                                 line=line + whole.count(b"\n"))
            if whole:
                yield line, whole
                line += whole.count(b"\n")
            if not chunk:
                return


def _stream(data_path: Path, columns: list[str], dt: float, wanted, source) -> np.ndarray:
    """Every row's ``wanted`` columns, block by block, each block checked before the next is read."""
    parts: list[np.ndarray] = []
    held, budget = 0, memory_available()
    for line, values, _ in _checked_blocks(data_path, columns, dt, wanted, source):
        parts.append(values)
        held += values.nbytes
        if 2 * held + BLOCK_BYTES > budget:
            raise InputError(data_path, f"more rows than fit in memory ({held / 1e9:.3g} GB read before line "
                             f"{line}, {budget / 1e9:.3g} GB available; a compression bomb?)")
    return np.concatenate(parts) if parts else np.zeros((0, len(wanted)))


def _checked_blocks(data_path: Path, columns: list[str], dt: float, wanted, source):
    """``(first line, values of the wanted columns, bytes of text)`` per block, each checked before the next is
    read."""
    last = None
    for line, block in _blocks(data_path, source):
        values = _block_values(data_path, columns, line, block, wanted)
        last = _check_block(data_path, values, line, block, dt, last)
        yield line, values, len(block)


def _block_values(data_path: Path, columns: list[str], line: int, block: bytes, wanted=COLUMNS) -> np.ndarray:
    """The ``wanted`` columns of one block of whole lines; a problem names its line and column."""
    take = [columns.index(c) for c in wanted]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)  # never drop fields silently
            frame = pd.read_csv(io.BytesIO(block), header=None, names=list(range(len(columns))), index_col=False,
                                dtype=np.float64, skipinitialspace=True, engine="c")
    except (ValueError, TypeError, pd.errors.ParserError, pd.errors.ParserWarning, pd.errors.EmptyDataError):
        return _block_rows(data_path, columns, take, line, block)
    values = frame.to_numpy(dtype=float)[:, take]
    if not np.all(np.isfinite(values)):
        return _block_rows(data_path, columns, take, line, block)  # names the text at fault
    return values


def _block_rows(data_path: Path, columns: list[str], take: list[int], line: int, block: bytes) -> np.ndarray:
    """One block read row by row (only after the fast parse failed) to name the first line at fault."""
    rows = []
    lines = block.split(b"\n")
    for k, raw in enumerate(lines[:-1] if lines[-1] == b"" else lines):
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InputError(data_path, f"not UTF-8 text (byte {raw[exc.start]:#04x})", line=line + k) from None
        try:
            row = next(csv.reader([text.rstrip("\r")], skipinitialspace=True), [])
        except csv.Error as exc:
            raise InputError(data_path, f"not a CSV row ({exc})", line=line + k) from None
        values = _row_values(data_path, columns, take, row, line + k)
        if values is not None:
            rows.append(values)
    return np.array(rows, dtype=float).reshape(-1, len(take))


def _row_values(data_path: Path, columns: list[str], take: list[int], row: list[str], line: int):
    """The format's values of one row (``None`` for a blank row); an error names the line and column."""
    if not row or row == [""]:
        return None
    if len(row) != len(columns):
        raise InputError(data_path, f"{len(row)} fields, the header has {len(columns)}", line=line)
    values = []
    for j in take:  # extra columns are ignored
        try:
            values.append(decimal_number(row[j]))
        except ValueError:
            raise InputError(data_path, f"{shown(row[j])} is not a finite number{_plain_only(row[j])}", line=line,
                             column=columns[j]) from None
    return values


def _plain_only(field: str) -> str:
    """A hint when Python would read ``field`` as a number (``1_000``, other scripts' digits) but we do not."""
    try:
        return " (only plain ASCII decimal numbers are read)" if math.isfinite(float(field)) else ""
    except ValueError:
        return ""


def _check_block(data_path: Path, values: np.ndarray, line: int, block: bytes, dt: float, last):
    """Pulses within :data:`MAX_PULSE`, time strictly increasing at the uniform rate (from the previous
    block's last time ``last``); returns this block's last time."""
    if not len(values):
        return last
    big = np.abs(values[:, 1:len(COLUMNS)]) > MAX_PULSE
    if big.any():
        row, col = np.argwhere(big)[0]
        raise InputError(data_path, f"{values[row, 1 + col]:.6g} is not a pulse count or increment (beyond "
                         f"{MAX_PULSE:.3g}): not a physical measurement", line=_line_of(block, line, row), column=PULSE_COLUMNS[col])
    time = values[:, 0] if last is None else np.concatenate([[last], values[:, 0]])
    fault = _time_fault(time, dt)
    if fault:
        k, message = fault
        raise InputError(data_path, message, line=_line_of(block, line, k - (0 if last is None else 1)))
    return float(values[-1, 0])


def _time_fault(time: np.ndarray, dt: float) -> tuple[int, str] | None:
    """The first sample ``k`` whose time does not increase, or not by ``dt``, and what is wrong; else None."""
    step = np.diff(time)
    bad = step <= 0
    if bad.any():
        k = int(np.argmax(bad)) + 1
        return k, f"time {time[k]:.10g} does not increase (previous {time[k - 1]:.10g})"
    off = np.abs(step - dt) > TIME_TOLERANCE * dt
    if off.any():
        k = int(np.argmax(off)) + 1
        return k, f"time step {step[k - 1]:.6g} s differs from 1/rate_hz = {dt:.6g} s (time must be uniform)"
    return None


def check_time(data_path, values: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Time (the first column of ``values``) strictly increasing at the uniform rate, for samples that come
    as arrays (importers); returns ``(time, pulses)``."""
    if len(values) < 2:
        raise InputError(data_path, "fewer than two samples")
    fault = _time_fault(values[:, 0], 1.0 / rate_hz)
    if fault:
        raise InputError(data_path, fault[1], line=fault[0] + 2)
    return values[:, 0], values[:, 1:]


def _line_of(block: bytes, line: int, row: int) -> int:
    """The file's line number of the block's ``row``-th row of values (blank lines skipped)."""
    if block.count(b"\n\n") == 0 and b"\n\r\n" not in block and not block.startswith((b"\n", b"\r\n")):
        return line + row
    seen = -1
    for k, raw in enumerate(block.split(b"\n")):
        if raw.strip():
            seen += 1
            if seen == row:
                return line + k
    return line + row


def _raise_encoding_error(data_path: Path, source):
    """Name the line of the first byte that is not UTF-8."""
    line = 1
    with source() as handle:
        for line, raw in enumerate(handle, start=1):
            try:
                raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise InputError(data_path, f"not UTF-8 text (byte {raw[exc.start]:#04x})", line=line) from None
    raise InputError(data_path, "not UTF-8 text")


#: Rows per chunk when writing a CSV (a 14-million-row file never exists as one string).
CSV_CHUNK = 500_000


def samples_csv(time: np.ndarray, gyro: np.ndarray, accel: np.ndarray, rows: slice | None = None,
                header: bool = True, temperature: np.ndarray | None = None, reference: np.ndarray | None = None) -> str:
    """CSV text of samples; floats in shortest round-trip form, integral pulses as integers; the
    ``temperature`` column and the reference attitude (:data:`REFERENCE_COLUMNS`, (N, 3) deg) last when given."""
    rows = rows or slice(None)
    frame = pd.DataFrame({"time": np.round(time[rows], 9)})
    for j, col in enumerate(PULSE_COLUMNS):
        whole = gyro[:, j] if j < 3 else accel[:, j - 3]
        integral = np.all(whole == np.round(whole)) and np.abs(whole).max(initial=0) < 2**53
        frame[col] = whole[rows].astype(np.int64) if integral else whole[rows]
    if temperature is not None:
        frame[TEMPERATURE_COLUMN] = temperature[rows]
    if reference is not None:
        for j, col in enumerate(REFERENCE_COLUMNS):
            frame[col] = reference[rows, j]
    return frame.to_csv(index=False, header=header, lineterminator="\n")


def samples_writer(rec):
    """A function writing the CSV of a recording into a binary file object, in chunks (see
    :func:`core.files.write_files`)."""

    def write(handle) -> None:
        for chunk in samples_chunks(rec):
            handle.write(chunk)

    return write


def samples_chunks(rec):
    """The CSV of a recording's samples as bytes, :data:`CSV_CHUNK` rows at a time."""
    reference = None if rec.reference is None else np.degrees(rec.reference)
    for first in range(0, max(len(rec.time), 1), CSV_CHUNK):
        yield samples_csv(rec.time, rec.gyro, rec.accel, slice(first, first + CSV_CHUNK), header=first == 0,
                          temperature=rec.temperature, reference=reference).encode("utf-8")


class _ChunkStream(io.RawIOBase):
    """A binary file object reading the bytes of an iterable of chunks (made as they are read)."""

    def __init__(self, chunks):
        self._chunks, self._left = iter(chunks), b""

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        while not self._left:
            self._left = next(self._chunks, None)
            if self._left is None:
                self._left = b""
                return 0
        n = min(len(buffer), len(self._left))
        buffer[:n], self._left = self._left[:n], self._left[n:]
        return n


def samples_as_read(rec, data_path) -> tuple:
    """``(time, pulses, temperature, reference)`` of a recording's samples as :func:`read_samples` reads them
    back once written as the CSV ``data_path``: the same text, made in memory a chunk at a time, through the
    same reader and its checks (nothing is written)."""
    return read_samples(Path(data_path), rec.rate_hz, with_temperature=True, with_reference=True,
                        source=lambda: io.BufferedReader(_ChunkStream(samples_chunks(rec)), BLOCK_BYTES))
