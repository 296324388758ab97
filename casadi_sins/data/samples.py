"""The CSV of raw pulse increments: ``time, gyro_x..z, accel_x..z`` (extra columns are ignored).

``time`` is the end of each sample interval, strictly increasing at the uniform rate ``rate_hz``;
pulses may be floats or integers.  ``.gz``, ``.bz2``, ``.xz`` and ``.zip`` files are read as such.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..core.errors import InputError
from ..core.files import atomic_open
from .recording import COLUMNS, PULSE_COLUMNS, TIME_TOLERANCE


def read_samples(data_path: Path, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Time and pulses of the CSV (``.gz``, ``.bz2``, ``.xz``, ``.zip`` are read as such).

    Floats are parsed directly (8 bytes a value: 14 million rows in about 1 GB); only when that fails is
    the file read again as text, to name the line and column at fault.
    """
    if data_path.is_dir():
        raise InputError(data_path, "is a folder; 'data' must name the CSV of samples")
    try:
        header = pd.read_csv(data_path, nrows=0, skipinitialspace=True)
    except FileNotFoundError:
        raise InputError(data_path, "data file not found") from None
    except UnicodeDecodeError:
        _raise_encoding_error(data_path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise InputError(data_path, f"not a readable CSV ({exc})") from None
    except OSError as exc:
        raise InputError(data_path, f"cannot be read ({exc.strerror or exc})") from None
    names = {str(c).strip(): c for c in header.columns}
    missing = [c for c in COLUMNS if c not in names]
    if missing:
        raise InputError(data_path, f"missing column(s) {', '.join(missing)}; header must contain "
                         f"{','.join(COLUMNS)}", line=1)
    try:
        try:
            frame = pd.read_csv(data_path, usecols=[names[c] for c in COLUMNS], dtype=np.float64,
                                skipinitialspace=True, engine="c")
            values = frame[[names[c] for c in COLUMNS]].to_numpy(dtype=float)
            if not np.all(np.isfinite(values)):
                values = _read_samples_slowly(data_path, names)  # names the text at fault
        except (ValueError, TypeError) as exc:
            if isinstance(exc, (InputError, UnicodeDecodeError)):
                raise
            values = _read_samples_slowly(data_path, names)
    except UnicodeDecodeError:
        _raise_encoding_error(data_path)
    except (pd.errors.ParserError, OSError) as exc:
        raise InputError(data_path, f"not a readable CSV ({exc})") from None
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


def _read_samples_slowly(data_path: Path, names: dict) -> np.ndarray:
    """Read as text to name the first value that is not a finite number."""
    frame = pd.read_csv(data_path, dtype=str, keep_default_na=False, skipinitialspace=True,
                        usecols=[names[c] for c in COLUMNS])
    values = np.empty((len(frame), len(COLUMNS)))
    for j, col in enumerate(COLUMNS):
        numeric = pd.to_numeric(frame[names[col]], errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(numeric)
        if bad.any():
            row = int(np.argmax(bad))
            raise InputError(data_path, f"{frame[names[col]].iloc[row]!r} is not a finite number", line=row + 2,
                             column=col)
        values[:, j] = numeric
    return values


def _raise_encoding_error(data_path: Path):
    """Name the line of the first byte that is not UTF-8."""
    import gzip

    opener = gzip.open if data_path.suffix == ".gz" else open
    line = 1
    with opener(data_path, "rb") as handle:
        for line, raw in enumerate(handle, start=1):
            try:
                raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise InputError(data_path, f"not UTF-8 text (byte {raw[exc.start]:#04x})", line=line) from None
    raise InputError(data_path, "not UTF-8 text")


#: Rows per chunk when writing a CSV (a 14-million-row file never exists as one string).
CSV_CHUNK = 500_000


def samples_csv(time: np.ndarray, gyro: np.ndarray, accel: np.ndarray, rows: slice | None = None,
                header: bool = True) -> str:
    """CSV text of samples; floats in shortest round-trip form, integral pulses as integers."""
    rows = rows or slice(None)
    frame = pd.DataFrame({"time": np.round(time[rows], 9)})
    for j, col in enumerate(PULSE_COLUMNS):
        whole = gyro[:, j] if j < 3 else accel[:, j - 3]
        integral = np.all(whole == np.round(whole)) and np.abs(whole).max(initial=0) < 2**53
        frame[col] = whole[rows].astype(np.int64) if integral else whole[rows]
    return frame.to_csv(index=False, header=header, lineterminator="\n")


def write_samples(path: Path, rec) -> Path:
    """The CSV of a recording, written in chunks to a temporary file and renamed when complete."""
    with atomic_open(path, "w", encoding="utf-8", newline="") as handle:
        for first in range(0, len(rec.time), CSV_CHUNK):
            handle.write(samples_csv(rec.time, rec.gyro, rec.accel, slice(first, first + CSV_CHUNK),
                                     header=first == 0))
    return path
