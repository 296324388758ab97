"""Importers: samples held in other tools' files, as a recording of the interchange format.

* ``psins``: PSINS's ``imu = [wm vm t]`` array (gyro increments rad, velocity increments m/s, time s),
  in a ``.mat`` file (variable ``imu`` unless named) or a text file of seven columns;
* ``mat``: a MATLAB ``.mat`` file, arrays by variable name;
* ``hdf5``: an HDF5 file, datasets by path;
* ``parquet``: a Parquet table, columns by name.

Names (``--map KEY=NAME``) default to the format's own: ``time``, ``gyro_x`` ... ``accel_z`` (or ``gyro``
and ``accel`` holding three columns), and an optional ``temperature``.  The readers are well-kept
libraries, optional extras: SciPy's ``loadmat`` (``mat``), h5py (``hdf5``), pyarrow (``parquet``); a
missing one is a one-line error naming the extra.  :func:`import_samples` returns time, pulses and
temperature; the caller adds the description (a given one's site and segments, or ``segment``'s).
"""

from __future__ import annotations

import dataclasses
import importlib
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.extras import missing_extra
from .recording import PULSE_COLUMNS, Recording, check_physical_range, check_rate, validate_schedule
from .samples import check_time
from .segmentation import segment_recording

FORMATS = ("psins", "mat", "hdf5", "parquet")
#: The extra to install for each reader (``pip install "casadi-sins[EXTRA]"``, :func:`core.extras.missing_extra`).
EXTRAS = {"scipy.io": "mat", "h5py": "hdf5", "pyarrow.parquet": "parquet"}
KEYS = ("time",) + PULSE_COLUMNS + ("gyro", "accel", "temperature")


def _module(name: str):
    """An optional reader, or a one-line error naming the extra that brings it."""
    try:
        return importlib.import_module(name)
    except ImportError:
        raise InputError(None, missing_extra("reading this format", EXTRAS[name], name.split(".")[0])) from None


def parse_map(items) -> dict[str, str]:
    """``["time=t", "gyro=w"]`` as ``{"time": "t", "gyro": "w"}``; an unknown key is an InputError."""
    out = {}
    for item in items or ():
        key, sep, name = str(item).partition("=")
        if not sep or key.strip() not in KEYS or not name.strip():
            raise InputError(None, f"--map {item!r}: expected KEY=NAME with KEY one of {', '.join(KEYS)}")
        out[key.strip()] = name.strip()
    return out


def _columns(get, names: dict[str, str], src) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Time, pulses (N, 6) and temperature from a lookup ``get(name) -> array or None``."""
    def fetch(key, required=True):
        name = names.get(key, key)
        value = get(name)
        if value is None and required:
            raise InputError(src, f"no {key} (looked for {name!r}; --map {key}=NAME names another)")
        return None if value is None else np.asarray(value, dtype=float)

    time = fetch("time").ravel()
    blocks = []
    for sensor in ("gyro", "accel"):
        per_axis = [c for c in PULSE_COLUMNS if c.startswith(sensor)]
        separate = all(get(names.get(c, c)) is None for c in per_axis)
        whole = fetch(sensor) if sensor in names or (separate and get(sensor) is not None) else None
        if whole is None:
            blocks.append(np.column_stack([fetch(c).ravel() for c in per_axis]))
            continue
        whole = whole if whole.ndim == 2 and whole.shape[1] == 3 else whole.T
        if whole.ndim != 2 or whole.shape[1] != 3:
            raise InputError(src, f"{names.get(sensor, sensor)!r} must have three columns, has shape {whole.shape}")
        blocks.append(whole)
    pulses = np.column_stack(blocks)
    temperature = fetch("temperature", required=False)
    if len(pulses) != len(time) or (temperature is not None and temperature.size != len(time)):
        raise InputError(src, f"time has {len(time)} rows, the pulses {len(pulses)}: the arrays must be of one length")
    return time, pulses, None if temperature is None else temperature.ravel()


def _read_psins(src: Path, names: dict[str, str]):
    """``[wm vm t]``: a .mat variable (``imu`` unless ``--map gyro=NAME`` names the array) or a text file."""
    if src.suffix.lower() == ".mat":
        data = _mat(src)
        name = names.get("gyro", "imu")
        if name not in data:
            raise InputError(src, f"no variable {name!r} ([wm vm t]; --map gyro=NAME names another)")
        array = np.asarray(data[name], dtype=float)
    else:
        try:
            array = np.loadtxt(src, delimiter="," if src.suffix.lower() == ".csv" else None, ndmin=2)
        except ValueError as exc:
            raise InputError(src, f"not a text table of numbers ({exc})") from None
    if array.ndim != 2 or array.shape[1] < 7:
        raise InputError(src, f"a PSINS [wm vm t] array has 7 columns, found shape {array.shape}")
    return array[:, 6], array[:, :6], None


def _mat(src: Path) -> dict:
    io = _module("scipy.io")
    try:
        return {k: v for k, v in io.loadmat(src).items() if not k.startswith("__")}
    except (ValueError, TypeError, OSError, NotImplementedError) as exc:
        raise InputError(src, f"not a MATLAB .mat file SciPy reads (v7.3 files are HDF5: import hdf5) ({exc})") from None


def _read_hdf5(src: Path, names: dict[str, str]):
    h5py = _module("h5py")
    try:
        with h5py.File(src, "r") as handle:
            def get(name):
                return np.asarray(handle[name]) if name in handle else None
            return _columns(get, names, src)
    except OSError as exc:
        raise InputError(src, f"not an HDF5 file ({exc})") from None


def _read_parquet(src: Path, names: dict[str, str]):
    pq = _module("pyarrow.parquet")
    try:
        table = pq.read_table(src)
    except Exception as exc:  # noqa: BLE001 (pyarrow raises its own error types)
        raise InputError(src, f"not a Parquet file ({type(exc).__name__}: {exc})") from None
    columns = set(table.column_names)
    return _columns(lambda name: table.column(name).to_numpy() if name in columns else None, names, src)


def import_samples(kind: str, src, names: dict[str, str] | None = None):
    """``(time, pulses (N, 6), temperature or None)`` of a file of another tool (module docstring).

    Raises
    ------
    InputError
        One line naming the file and what is missing or wrong, or the extra to install.
    """
    src, names = Path(src), names or {}
    if not src.is_file():
        raise InputError(src, "no such file")
    if kind == "psins":
        time, pulses, temperature = _read_psins(src, names)
    elif kind == "mat":
        data = _mat(src)
        time, pulses, temperature = _columns(data.get, names, src)
    elif kind == "hdf5":
        time, pulses, temperature = _read_hdf5(src, names)
    elif kind == "parquet":
        time, pulses, temperature = _read_parquet(src, names)
    else:
        raise InputError(None, f"unknown format {kind!r}; one of {', '.join(FORMATS)}")
    if len(time) < 2 or not (np.all(np.isfinite(time)) and np.all(np.isfinite(pulses))):
        raise InputError(src, "fewer than two samples, or values that are not finite numbers")
    return time, pulses, temperature


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
