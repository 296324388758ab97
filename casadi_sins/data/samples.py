"""The CSV of raw pulse increments: ``time, gyro_x..z, accel_x..z`` (extra columns are ignored).

An optional ``temperature`` column (degC per sample) is read when asked for.

``time`` is the end of each sample interval, strictly increasing at the uniform rate ``rate_hz``;
pulses may be floats or integers.  ``.gz``, ``.bz2``, ``.xz`` and ``.zip`` files are read as such.
"""

from __future__ import annotations

import csv
import io
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.errors import InputError, shown
from ..core.inputs import check_input_file, check_memory_for, decompression_errors, first_line, open_binary
from .recording import COLUMNS, PULSE_COLUMNS, TIME_TOLERANCE

#: The optional column of the unit's temperature, degC.
TEMPERATURE_COLUMN = "temperature"


#: More columns than this is not a CSV of samples (the format has 7; extra columns are allowed).
MAX_COLUMNS = 1000
_FIELDS = re.compile(r"Expected (\d+) fields in line (\d+), saw (\d+)")


def read_samples(data_path: Path, rate_hz: float, with_temperature: bool = False) -> tuple:
    """Time and pulses of the CSV (``.gz``, ``.bz2``, ``.xz``, ``.zip`` are read as such).

    With ``with_temperature`` a third item: the ``temperature`` column (degC), or None without one.

    Every row must have exactly the header's number of fields (a comma inside a number would shift the
    columns); the columns are found by name, extra ones are ignored.  Floats are parsed directly (8 bytes
    a value: 14 million rows in about 1 GB); only when that fails is the file read again row by row, to
    name the line and column at fault.

    Raises
    ------
    InputError
        Naming the file, line and column of the first problem.
    """
    size = check_input_file(data_path, "data file (the CSV of samples that 'data' must name)")
    check_memory_for(data_path, size)
    try:
        columns = _header(data_path)
        wanted = COLUMNS + ((TEMPERATURE_COLUMN,) if with_temperature and TEMPERATURE_COLUMN in columns else ())
        values = _parse(data_path, columns, wanted)
    except InputError:
        raise
    except MemoryError:
        raise InputError(data_path, "not enough memory to read it") from None
    except UnicodeDecodeError:
        _raise_encoding_error(data_path)
    except pd.errors.EmptyDataError:
        raise InputError(data_path, "fewer than two samples") from None
    except decompression_errors() as exc:
        raise InputError(data_path, f"cannot be read: truncated or corrupt ({exc.strerror or exc})"
                         if isinstance(exc, OSError) else f"cannot be read: truncated or corrupt ({exc})") from None
    time, pulses = check_time(data_path, values[:, :len(COLUMNS)], rate_hz)
    if not with_temperature:
        return time, pulses
    return time, pulses, (values[:, len(COLUMNS)].copy() if len(wanted) > len(COLUMNS) else None)


def _header(data_path: Path) -> list[str]:
    """The header's column names (stripped), checked for the format's columns."""
    line = first_line(data_path)
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


def _parse(data_path: Path, columns: list[str], wanted=COLUMNS) -> np.ndarray:
    """All rows as floats, the ``wanted`` columns in order; every row with exactly the header's fields."""
    width = len(columns)
    take = [columns.index(c) for c in wanted]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)  # never drop fields silently
            frame = pd.read_csv(data_path, header=None, skiprows=1, names=list(range(width)), index_col=False,
                                dtype=np.float64, skipinitialspace=True, engine="c")
    except pd.errors.ParserError as exc:
        found = _FIELDS.search(str(exc))
        if found:
            raise InputError(data_path, f"{found.group(3)} fields, the header has {found.group(1)}",
                             line=int(found.group(2))) from None
        return _read_rows(data_path, columns, wanted)
    except (ValueError, TypeError, pd.errors.ParserWarning):
        return _read_rows(data_path, columns, wanted)  # names the text at fault
    values = frame.to_numpy(dtype=float)[:, take]
    if len(frame) and (not np.all(np.isfinite(values)) or frame.isna().to_numpy().any()):
        return _read_rows(data_path, columns, wanted)
    return values


def _read_rows(data_path: Path, columns: list[str], wanted=COLUMNS) -> np.ndarray:
    """Read row by row (only after the fast parse failed) to name the first line at fault."""
    take = [columns.index(c) for c in wanted]
    rows = []
    with io.TextIOWrapper(open_binary(data_path), encoding="utf-8", newline="") as handle:
        reader = csv.reader(handle, skipinitialspace=True)
        try:
            next(reader, None)
            for row in reader:
                rows.append(_row_values(data_path, columns, take, row, reader.line_num))
        except csv.Error as exc:  # an unmatched quote runs a field over many lines
            raise InputError(data_path, f"not a CSV row ({exc})", line=reader.line_num) from None
    return np.array([r for r in rows if r is not None], dtype=float).reshape(-1, len(wanted))


def _row_values(data_path: Path, columns: list[str], take: list[int], row: list[str], line: int):
    """The format's values of one row (``None`` for a blank row); an error names the line and column."""
    if not row or row == [""]:
        return None
    if len(row) != len(columns):
        raise InputError(data_path, f"{len(row)} fields, the header has {len(columns)}", line=line)
    values = []
    for j in take:
        try:
            value = float(row[j])
        except ValueError:
            value = float("nan")
        if not math.isfinite(value):
            raise InputError(data_path, f"{shown(row[j])} is not a finite number", line=line, column=columns[j])
        values.append(value)
    return values


def check_time(data_path, values: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Time strictly increasing at the uniform rate; returns ``(time, pulses)``."""
    if len(values) < 2:
        raise InputError(data_path, "fewer than two samples")
    time = values[:, 0]
    step = np.diff(time)
    dt = 1.0 / rate_hz
    if (step <= 0).any():
        row = int(np.argmax(step <= 0)) + 1
        raise InputError(data_path, f"time {time[row]:.10g} does not increase (previous {time[row - 1]:.10g})",
                         line=row + 2)
    off = np.abs(step - dt) > TIME_TOLERANCE * dt
    if off.any():
        row = int(np.argmax(off)) + 1
        raise InputError(data_path, f"time step {step[row - 1]:.6g} s differs from 1/rate_hz = {dt:.6g} s (time "
                         "must be uniform)", line=row + 2)
    return time, values[:, 1:]


def _raise_encoding_error(data_path: Path):
    """Name the line of the first byte that is not UTF-8."""
    line = 1
    with open_binary(data_path) as handle:
        for line, raw in enumerate(handle, start=1):
            try:
                raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise InputError(data_path, f"not UTF-8 text (byte {raw[exc.start]:#04x})", line=line) from None
    raise InputError(data_path, "not UTF-8 text")


#: Rows per chunk when writing a CSV (a 14-million-row file never exists as one string).
CSV_CHUNK = 500_000


def samples_csv(time: np.ndarray, gyro: np.ndarray, accel: np.ndarray, rows: slice | None = None,
                header: bool = True, temperature: np.ndarray | None = None) -> str:
    """CSV text of samples; floats in shortest round-trip form, integral pulses as integers; the
    ``temperature`` column last when given."""
    rows = rows or slice(None)
    frame = pd.DataFrame({"time": np.round(time[rows], 9)})
    for j, col in enumerate(PULSE_COLUMNS):
        whole = gyro[:, j] if j < 3 else accel[:, j - 3]
        integral = np.all(whole == np.round(whole)) and np.abs(whole).max(initial=0) < 2**53
        frame[col] = whole[rows].astype(np.int64) if integral else whole[rows]
    if temperature is not None:
        frame[TEMPERATURE_COLUMN] = temperature[rows]
    return frame.to_csv(index=False, header=header, lineterminator="\n")


def samples_writer(rec):
    """A function writing the CSV of a recording into a binary file object, in chunks (see
    :func:`core.files.write_files`)."""

    def write(handle) -> None:
        for first in range(0, len(rec.time), CSV_CHUNK):
            handle.write(samples_csv(rec.time, rec.gyro, rec.accel, slice(first, first + CSV_CHUNK),
                                     header=first == 0, temperature=rec.temperature).encode("utf-8"))

    return write
