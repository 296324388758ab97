"""Importers: samples held in other tools' files, as a recording of the interchange format.

* ``psins``: PSINS's ``imu = [wm vm t]`` array (gyro increments rad, velocity increments m/s, time s),
  in a ``.mat`` file (variable ``imu`` unless named) or a text file of seven columns;
* ``mat``: a MATLAB ``.mat`` file, arrays by variable name;
* ``hdf5``: an HDF5 file, datasets by path;
* ``parquet``: a Parquet table, columns by name.

Names (``--map KEY=NAME``) default to the format's own: ``time``, ``gyro_x`` ... ``accel_z`` (or ``gyro``
and ``accel`` holding three columns), and an optional ``temperature``.  The readers are well-kept
libraries, optional extras: SciPy's ``loadmat`` (``mat``), h5py (``hdf5``), pyarrow (``parquet``); a
missing one is a one-line error naming the extra (:mod:`data.foreign`).  :func:`import_samples` returns
time, pulses and temperature, read a block of rows at a time and checked as they come (finite, pulses
within range, time increasing): a file declaring more rows than it holds is refused on its first block,
and every declared size is judged against the memory available before anything is allocated.  The
caller adds the description (a given one's site and segments, or ``segment``'s).
"""

from __future__ import annotations

import contextlib
import dataclasses
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.inputs import check_input_file, check_memory_for, memory_available
from .formats import IMPORT_FORMATS, IMPORT_KEYS
from .foreign import ArraySource, ParquetSource, Source, check_declared, hdf5_source, mat_source, sample_axis, text_table
from .recording import PULSE_COLUMNS, Recording, check_physical_range, check_rate, validate_schedule
from .samples import MAX_PULSE, check_time
from .segmentation import segment_recording

FORMATS, KEYS = IMPORT_FORMATS, IMPORT_KEYS
#: Rows read and checked at a time: memory is the arrays read so far plus about one block.
BLOCK_ROWS = 1 << 18


def parse_map(items) -> dict[str, str]:
    """``["time=t", "gyro=w"]`` as ``{"time": "t", "gyro": "w"}``; an unknown key is an InputError."""
    out = {}
    for item in items or ():
        key, sep, name = str(item).partition("=")
        if not sep or key.strip() not in KEYS or not name.strip():
            raise InputError(None, f"--map {item!r}: expected KEY=NAME with KEY one of {', '.join(KEYS)}")
        out[key.strip()] = name.strip()
    return out


@dataclasses.dataclass(frozen=True)
class Column:
    """Where one of the format's columns (``time``, ``gyro_x`` ... ``temperature``) is in a file: the array
    ``name``, its sample ``axis`` and the column ``index`` within it (None: the array is one column)."""

    key: str
    name: str
    axis: int
    index: int | None = None


def _layout(source: Source, names: dict[str, str]) -> list[Column]:
    """Where each column is (module docstring), every array's shape checked and all of one length."""
    def array(key: str, columns: int, required: bool = True):
        name = names.get(key, key)
        shape = source.shape(name)
        if shape is None:
            if required:
                raise InputError(source.path, f"no {key} (looked for {name!r}; --map {key}=NAME names another)")
            return None
        axis = sample_axis(shape, columns)
        if axis is None:
            want = "one column" if columns == 1 else "three columns"
            raise InputError(source.path, f"{name!r} must have {want}, has shape {'x'.join(map(str, shape)) or '()'}")
        return name, axis, shape[axis]

    time = array("time", 1)
    found = [(Column("time", *time[:2]), time[2])]
    for sensor in ("gyro", "accel"):
        per_axis = [c for c in PULSE_COLUMNS if c.startswith(sensor)]
        separate = all(source.shape(names.get(c, c)) is None for c in per_axis)
        whole = array(sensor, 3) if sensor in names or (separate and source.shape(sensor) is not None) else None
        if whole is None:
            for c in per_axis:
                name, axis, rows = array(c, 1)
                found.append((Column(c, name, axis), rows))
        else:
            found += [(Column(c, whole[0], whole[1], j), whole[2]) for j, c in enumerate(per_axis)]
    temperature = array("temperature", 1, required=False)
    if temperature is not None:
        found.append((Column("temperature", *temperature[:2]), temperature[2]))
    lengths = {}
    for column, rows in found:
        lengths.setdefault(column.name, rows)
    if len(set(lengths.values())) > 1:
        shown = ", ".join(f"{name!r} {rows}" for name, rows in lengths.items())
        raise InputError(source.path, f"the arrays must be of one length, they have {shown} rows")
    return [column for column, _ in found]


def _read(source: Source, layout: list[Column]) -> np.ndarray:
    """Every column of ``layout``, a block of rows at a time, each block checked before the next is read:
    finite, pulses within :data:`~data.samples.MAX_PULSE`, time strictly increasing.  Stops at the first fault,
    naming the row; the memory held is the rows read so far (checked against the memory available) plus one
    block, so an array declaring far more rows than the file holds is refused on its first block."""
    axes = {column.name: column.axis for column in layout}
    first = layout[0]
    rows = source.shape(first.name)[first.axis]
    check_declared(source.path, float(rows) * len(layout), streamed=not isinstance(source, ArraySource))
    parts, held, budget, last = [], 0, memory_available(), None
    try:
        for start, arrays in source.blocks(axes, rows, BLOCK_ROWS):
            block = np.column_stack([_column(arrays[c.name], c) for c in layout]).astype(float, copy=False)
            last = _check_block(source.path, layout, block, start, last)
            parts.append(block)
            held += block.nbytes
            if 2 * held > budget:
                raise InputError(source.path, f"more rows than fit in memory ({held / 1e9:.3g} GB read before row "
                                 f"{start + 1}, {budget / 1e9:.3g} GB available)")
        return np.concatenate(parts) if parts else np.zeros((0, len(layout)))
    except MemoryError:
        raise InputError(source.path, "not enough memory to read it") from None


def _column(values: np.ndarray, column: Column) -> np.ndarray:
    values = np.asarray(values)
    return values.reshape(len(values), -1)[:, 0 if column.index is None else column.index]


def _check_block(path: Path, layout: list[Column], block: np.ndarray, start: int, last: float | None):
    """Finite values, pulses within :data:`MAX_PULSE`, time strictly increasing from ``last`` (the previous
    block's last time); returns this block's last time."""
    bad = ~np.isfinite(block)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise InputError(path, f"{layout[col].key} ({layout[col].name!r}) at row {start + row + 1} is "
                         f"{block[row, col]}, not a finite number")
    pulses = [k for k, c in enumerate(layout) if c.key in PULSE_COLUMNS]
    big = np.abs(block[:, pulses]) > MAX_PULSE
    if big.any():
        row, col = np.argwhere(big)[0]
        raise InputError(path, f"{layout[pulses[col]].key} at row {start + row + 1} is {block[row, pulses[col]]:.6g}: "
                         f"not a pulse count or increment (beyond {MAX_PULSE:.3g})")
    time = block[:, 0] if last is None else np.concatenate([[last], block[:, 0]])
    step = np.diff(time)
    if (step <= 0).any():
        k = int(np.argmax(step <= 0)) + 1
        row = start + k + (0 if last is None else -1)
        raise InputError(path, f"time at row {row + 1} ({time[k]:.10g}) does not increase (previous {time[k - 1]:.10g})")
    return float(block[-1, 0]) if len(block) else last


def _psins_source(src: Path, names: dict[str, str]) -> ArraySource:
    """``[wm vm t]``: a .mat variable (``imu`` unless ``--map gyro=NAME`` names the array) or a text file."""
    if src.suffix.lower() == ".mat":
        name = names.get("gyro", "imu")
        source = mat_source(src, [name])
        if source.shape(name) is None:
            raise InputError(src, f"no variable {name!r} ([wm vm t]; --map gyro=NAME names another)")
        array = source.arrays[name]
    else:
        check_memory_for(src, src.stat().st_size)
        array = text_table(src)
    if array.ndim != 2 or array.shape[1] < 7:
        raise InputError(src, f"a PSINS [wm vm t] array has 7 columns, found shape {'x'.join(map(str, array.shape))}")
    return ArraySource(src, {"time": array[:, 6], "gyro": array[:, :3], "accel": array[:, 3:6]})


@contextlib.contextmanager
def _source(kind: str, src: Path, names: dict[str, str]):
    if kind == "psins":
        yield _psins_source(src, names), {}
    elif kind == "mat":
        wanted = [names.get(k, k) for k in KEYS]
        yield mat_source(src, wanted), names
    elif kind == "hdf5":
        with hdf5_source(src) as source:
            yield source, names
    elif kind == "parquet":
        yield ParquetSource(src), names
    else:
        raise InputError(None, f"unknown format {kind!r}; one of {', '.join(FORMATS)}")


def import_samples(kind: str, src, names: dict[str, str] | None = None):
    """``(time, pulses (N, 6), temperature or None)`` of a file of another tool (module docstring), read a
    block of rows at a time and checked as it is read.

    Raises
    ------
    InputError
        One line naming the file and what is missing or wrong, or the extra to install.
    """
    src, names = Path(src), names or {}
    if kind not in FORMATS:
        raise InputError(None, f"unknown format {kind!r}; one of {', '.join(FORMATS)}")
    check_input_file(src, f"{kind} file")
    with _source(kind, src, names) as (source, mapped):
        layout = _layout(source, mapped)
        values = _read(source, layout)
    if len(values) < 2:
        raise InputError(src, "fewer than two samples")
    temperature = values[:, 7].copy() if len(layout) > 7 else None
    return values[:, 0], values[:, 1:7], temperature


def rate_of(time: np.ndarray) -> float:
    """The sample rate of a time column (its mean step), to nine significant digits."""
    step = (time[-1] - time[0]) / (len(time) - 1)
    if not step > 0:
        raise InputError(None, "the time column does not increase")
    return float(f"{1.0 / step:.9g}")


def imported_recording(time, pulses, temperature, name: str, template: dict | None = None,
                       rate_hz: float | None = None, site=None, label: str = "import"):
    """A validated :class:`~data.recording.Recording` of imported samples: its schedule from a description
    (``template``, :func:`data.description.read_description`: site, rate, segments, conditions) or, without
    one, found by :func:`data.segmentation.segment_recording` at ``site``; ``(recording, notes)``.

    Raises
    ------
    InputError
        Naming what is wrong: the time column against the rate, a schedule the samples do not fit.
    """
    rate = rate_hz or (template["rate_hz"] if template else rate_of(time))
    time, pulses = check_time(label, np.column_stack([time, pulses]), rate)
    if template is None or not template["segments"]:  # no schedule given: found at the site (a description's)
        site = template["site"] if template else site
        if site is None:
            raise InputError(None, "no description to take the segments from (--segments) and no site to find them "
                                   "(--latitude)")
        rec, notes = segment_recording(time, pulses[:, :3], pulses[:, 3:], rate, site, name)
        return dataclasses.replace(rec, temperature=temperature,
                                   conditions=template["conditions"] if template else rec.conditions), notes
    rec = Recording(name=name, site=template["site"], rate_hz=rate, segments=template["segments"], time=time,
                    gyro=pulses[:, :3], accel=pulses[:, 3:], warnings=list(template["warnings"]),
                    conditions=template["conditions"], temperature=temperature)
    warning = check_rate(time, rate, label)
    if warning:
        rec.warnings.append(warning)
    validate_schedule(rec)
    check_physical_range(rec, label)
    return rec, []
