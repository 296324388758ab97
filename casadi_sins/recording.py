"""The recording interchange format ``sins-recording/1``: read, validate, write.

A recording is a TOML description (site, sample rate, segments) beside a CSV
of raw pulse increments (``time, gyro_x..z, accel_x..z``).  Every problem
found is reported with the file and the line or segment it is in.
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

from . import frames
from .io import atomic_write_text

FORMAT = "sins-recording/1"
PULSE_COLUMNS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
COLUMNS = ("time",) + PULSE_COLUMNS
#: Two times closer than this fraction of a sample interval are the same instant.
TIME_TOLERANCE = 1e-3
#: The mean sample interval may differ from 1/rate_hz by this much (relative) unnoticed; up to
#: RATE_ERROR_LIMIT it is a warning (a time column from another clock), beyond that an error: every
#: scale factor would absorb it (100.05 Hz labelled 100 Hz is +500 ppm on each).
RATE_WARNING = 1e-6
RATE_ERROR_LIMIT = 1e-4
#: How far (s) a segment may reach past the first or last sample: time-tag conventions differ
#: (a segment "from 0 s" over data whose first interval starts at one sample period).
SEGMENT_OVERHANG_S = 1.0


class RecordingError(ValueError):
    """A recording that does not follow the interchange format; the message says where."""


@dataclasses.dataclass(frozen=True)
class Site:
    """Test site: latitude (rad), height (m) and the gravity magnitude in use (m/s^2)."""

    latitude: float
    height: float = 0.0
    gravity: float | None = None  # None: WGS-84 normal gravity

    @property
    def g(self) -> float:
        return self.gravity if self.gravity is not None else frames.normal_gravity(self.latitude, self.height)

    @property
    def earth_rate(self) -> np.ndarray:
        return frames.earth_rate_enu(self.latitude)

    @property
    def earth_rate_norm(self) -> float:
        return frames.EARTH_RATE


@dataclasses.dataclass(frozen=True)
class Segment:
    """One segment of the schedule.  ``number`` counts from 1 in file order."""

    number: int
    group: int
    kind: str  # "static" | "rotation"
    start: float
    end: float
    orientation: str | None = None  # static: nominal direction letters
    axis: str | None = None  # rotation: "+X" ... "-Z"
    angle_deg: float | None = None  # rotation: nominal angle

    @property
    def is_static(self) -> bool:
        return self.kind == "static"

    def describe(self) -> str:
        what = self.orientation if self.is_static else f"{self.axis} {self.angle_deg:g} deg"
        return f"segment {self.number} (group {self.group}, {self.kind} {what}, {self.start:g}-{self.end:g} s)"


@dataclasses.dataclass
class Recording:
    """A validated recording: description plus raw pulses.

    Attributes
    ----------
    time : ndarray (N,)
        End of each sample interval, s.
    gyro, accel : ndarray (N, 3)
        Raw pulse increments per interval.
    """

    name: str
    site: Site
    rate_hz: float
    segments: list[Segment]
    time: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    source: Path | None = None
    warnings: list[str] = dataclasses.field(default_factory=list)  # doubts about the data, for the reports

    @property
    def dt(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def label(self) -> str:
        return str(self.source) if self.source else self.name

    @property
    def file_stem(self) -> str:
        """The name as a file name: no folders, nothing but letters, digits and ``-_.``."""
        return safe_stem(self.name)

    @property
    def group_ids(self) -> list[int]:
        seen: list[int] = []
        for seg in self.segments:
            if seg.group not in seen:
                seen.append(seg.group)
        return seen

    def group_segments(self, group: int) -> list[Segment]:
        return [s for s in self.segments if s.group == group]

    def sample_range(self, start: float, end: float) -> slice:
        """Samples whose interval ``[t - dt, t]`` lies inside ``[start, end]``."""
        tol = TIME_TOLERANCE * self.dt
        first = int(np.searchsorted(self.time, start + self.dt - tol, side="left"))
        stop = int(np.searchsorted(self.time, end + tol, side="right"))
        return slice(first, max(first, stop))

    def segment_samples(self, seg: Segment) -> slice:
        return self.sample_range(seg.start, seg.end)

    def group_samples(self, group: int) -> slice:
        """All samples of a group, from its first segment's start to its last segment's end."""
        segs = self.group_segments(group)
        return self.sample_range(segs[0].start, segs[-1].end)

    @property
    def static_segments(self) -> list[Segment]:
        return [s for s in self.segments if s.is_static]

    def with_pulses(self, gyro: np.ndarray, accel: np.ndarray, name: str | None = None) -> "Recording":
        """A copy with other pulses (same time base and schedule)."""
        return dataclasses.replace(self, gyro=np.asarray(gyro, float), accel=np.asarray(accel, float),
                                   name=name or self.name, source=None)


def safe_stem(name: str) -> str:
    """A name usable as a file name inside an output folder (``../x`` cannot leave it)."""
    cleaned = "".join(c if c.isalnum() or c in "-_." else "-" for c in str(name).replace("\\", "/").split("/")[-1])
    return cleaned.strip(".") or "recording"


# --------------------------------------------------------------------------- reading
def read_recording(path: str | Path) -> Recording:
    """Read and validate a recording from its TOML description.

    Raises
    ------
    RecordingError
        With the file and the line or segment of the first problem found.
    """
    path = Path(path)
    doc = _read_toml(path)
    if doc.get("format") != FORMAT:
        raise RecordingError(f"{path}: format must be {FORMAT!r}, found {doc.get('format')!r}")
    name = _require(doc, "name", str, path)
    data_name = _require(doc, "data", str, path)
    if not data_name.strip():
        raise RecordingError(f"{path}: 'data' is empty; it must name the CSV of samples")
    site = _parse_site(doc.get("site"), path)
    imu = doc.get("imu")
    if not isinstance(imu, dict):
        raise RecordingError(f"{path}: missing [imu] table with rate_hz")
    rate_hz = _number(imu.get("rate_hz"), f"{path}: [imu] rate_hz")
    if not 1.0 <= rate_hz <= 1e5:
        raise RecordingError(f"{path}: [imu] rate_hz must be between 1 and 100000 Hz, found {rate_hz}")
    segments = _parse_segments(doc.get("segments"), path)
    data_path = (path.parent / data_name).resolve()
    time, pulses = _read_samples(data_path, rate_hz)
    rec = Recording(name=name, site=site, rate_hz=rate_hz, segments=segments, time=time,
                    gyro=pulses[:, :3], accel=pulses[:, 3:], source=path)
    rate_warning = check_rate(time, rate_hz, data_path)
    if rate_warning:
        rec.warnings.append(rate_warning)
    validate_schedule(rec)
    check_physical_range(rec, data_path)
    return rec


def _read_toml(path: Path) -> dict:
    """The description as a dictionary; every failure a :class:`RecordingError` naming the file (and line)."""
    if path.is_dir():
        raise RecordingError(f"{path}: is a folder; give the recording description NAME.toml")
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise RecordingError(f"{path}: no such recording description") from None
    except OSError as exc:
        raise RecordingError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise RecordingError(f"{path}, line {line}: not UTF-8 text (byte {raw[exc.start]:#04x})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RecordingError(f"{path}: not valid TOML: {exc}") from None


def _require(doc: dict, key: str, kind: type, where) -> object:
    value = doc.get(key)
    if not isinstance(value, kind):
        raise RecordingError(f"{where}: missing or invalid {key!r} (expected {kind.__name__})")
    return value


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise RecordingError(f"{where} must be a finite number, found {value!r}")
    return float(value)


def _parse_site(site, path: Path) -> Site:
    if not isinstance(site, dict):
        raise RecordingError(f"{path}: missing [site] table with latitude_deg")
    lat = _number(site.get("latitude_deg"), f"{path}: [site] latitude_deg")
    if not -90.0 <= lat <= 90.0:
        raise RecordingError(f"{path}: [site] latitude_deg {lat} is outside -90..90")
    height = _number(site.get("height_m", 0.0), f"{path}: [site] height_m")
    if not -500.0 <= height <= 10000.0:
        raise RecordingError(f"{path}: [site] height_m {height} is outside -500..10000 m (a test site on the ground)")
    gravity = site.get("gravity_mps2")
    if gravity is not None:
        gravity = _number(gravity, f"{path}: [site] gravity_mps2")
        if not 9.7 < gravity < 9.9:
            raise RecordingError(f"{path}: [site] gravity_mps2 {gravity} is not a gravity on Earth (9.7..9.9)")
    return Site(latitude=math.radians(lat), height=height, gravity=gravity)


def _parse_segments(items, path: Path) -> list[Segment]:
    if not isinstance(items, list) or not items:
        raise RecordingError(f"{path}: no [[segments]]")
    segments = []
    for number, item in enumerate(items, start=1):
        where = f"{path}: segment {number}"
        if not isinstance(item, dict):
            raise RecordingError(f"{where}: not a table")
        group = item.get("group")
        if isinstance(group, bool) or not isinstance(group, int):
            raise RecordingError(f"{where}: 'group' must be an integer, found {group!r}")
        kind = item.get("kind")
        start = _number(item.get("start_s"), f"{where}: start_s")
        end = _number(item.get("end_s"), f"{where}: end_s")
        if end <= start:
            raise RecordingError(f"{where}: end_s {end} is not after start_s {start}")
        if kind == "static":
            orientation = item.get("orientation")
            try:
                frames.orientation_to_dcm(orientation)
            except frames.OrientationError as exc:
                raise RecordingError(f"{where}: {exc}") from None
            segments.append(Segment(number, group, kind, start, end, orientation=orientation.upper()))
        elif kind == "rotation":
            axis = item.get("axis")
            try:
                frames.parse_axis(axis)
            except frames.OrientationError as exc:
                raise RecordingError(f"{where}: {exc}") from None
            angle = _number(item.get("angle_deg"), f"{where}: angle_deg")
            if angle == 0.0:
                raise RecordingError(f"{where}: angle_deg must not be zero")
            segments.append(Segment(number, group, kind, start, end, axis=axis.strip().upper(), angle_deg=angle))
        else:
            raise RecordingError(f"{where}: kind must be 'static' or 'rotation', found {kind!r}")
    return segments


def _read_samples(data_path: Path, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Time and pulses of the CSV (``.gz``, ``.bz2``, ``.xz``, ``.zip`` are read as such).

    Floats are parsed directly (8 bytes a value: 14 million rows in about 1 GB); only when that fails is
    the file read again as text, to name the line and column at fault.
    """
    if data_path.is_dir():
        raise RecordingError(f"{data_path}: is a folder; 'data' must name the CSV of samples")
    try:
        header = pd.read_csv(data_path, nrows=0, skipinitialspace=True)
    except FileNotFoundError:
        raise RecordingError(f"{data_path}: data file not found") from None
    except UnicodeDecodeError:
        _raise_encoding_error(data_path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise RecordingError(f"{data_path}: not a readable CSV ({exc})") from None
    except OSError as exc:
        raise RecordingError(f"{data_path}: cannot be read ({exc.strerror or exc})") from None
    names = {str(c).strip(): c for c in header.columns}
    missing = [c for c in COLUMNS if c not in names]
    if missing:
        raise RecordingError(f"{data_path}, line 1: missing column(s) {', '.join(missing)}; "
                             f"header must contain {','.join(COLUMNS)}")
    try:
        try:
            frame = pd.read_csv(data_path, usecols=[names[c] for c in COLUMNS], dtype=np.float64,
                                skipinitialspace=True, engine="c")
            values = frame[[names[c] for c in COLUMNS]].to_numpy(dtype=float)
            if not np.all(np.isfinite(values)):
                values = _read_samples_slowly(data_path, names)  # names the text at fault
        except (ValueError, TypeError) as exc:
            if isinstance(exc, (RecordingError, UnicodeDecodeError)):
                raise
            values = _read_samples_slowly(data_path, names)
    except UnicodeDecodeError:
        _raise_encoding_error(data_path)
    except (pd.errors.ParserError, OSError) as exc:
        raise RecordingError(f"{data_path}: not a readable CSV ({exc})") from None
    if len(values) < 2:
        raise RecordingError(f"{data_path}: fewer than two samples")
    time = values[:, 0]
    step = np.diff(time)
    dt = 1.0 / rate_hz
    if (step <= 0).any():
        row = int(np.argmax(step <= 0)) + 1
        raise RecordingError(f"{data_path}, line {row + 2}: time {time[row]!r} does not increase "
                             f"(previous {time[row - 1]!r})")
    off = np.abs(step - dt) > TIME_TOLERANCE * dt
    if off.any():
        row = int(np.argmax(off)) + 1
        raise RecordingError(f"{data_path}, line {row + 2}: time step {step[row - 1]:.6g} s differs from "
                             f"1/rate_hz = {dt:.6g} s (time must be uniform)")
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
            raise RecordingError(f"{data_path}, line {row + 2}, column {col}: "
                                 f"{frame[names[col]].iloc[row]!r} is not a finite number")
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
                raise RecordingError(f"{data_path}, line {line}: not UTF-8 text (byte {raw[exc.start]:#04x})") \
                    from None
    raise RecordingError(f"{data_path}: not UTF-8 text")


#: Beyond these no navigation-grade unit measures and no turntable moves: rad/s and m/s^2.
MAX_RATE = np.radians(2000.0)
MAX_SPECIFIC_FORCE = 100.0 * frames.G0


def check_physical_range(rec: "Recording", data_path) -> None:
    """Reject samples far beyond anything a unit on a turntable measures (1e300, a lost decimal point),
    naming the line.  The pulses' sizes are unknown here; robust rough ones come from the static
    segments' medians (1 g of specific force, the Earth rate), which a few wild samples cannot move."""
    statics = [rec.segment_samples(seg) for seg in rec.static_segments]
    if not statics:
        return
    for sensor, pulses, columns, magnitude, limit, unit in (
            ("gyro", rec.gyro, PULSE_COLUMNS[:3], rec.site.earth_rate_norm, MAX_RATE, "deg/s"),
            ("accel", rec.accel, PULSE_COLUMNS[3:], rec.site.g, MAX_SPECIFIC_FORCE, "g")):
        medians = np.array([np.median(pulses[sl], axis=0) for sl in statics])
        design = medians**2
        if not np.all(np.any(design > 0, axis=0)):
            continue
        u = np.linalg.lstsq(design, np.full(len(statics), (magnitude * rec.dt) ** 2), rcond=None)[0]
        if np.any(u <= 0):
            continue
        pulse_size = np.sqrt(u)  # per axis, SI per pulse
        values = np.abs(pulses) * pulse_size / rec.dt
        beyond = values > limit
        if beyond.any():
            row, col = np.argwhere(beyond)[0]
            shown = values[row, col] / (np.radians(1.0) if unit == "deg/s" else frames.G0)
            raise RecordingError(f"{data_path}, line {row + 2}, column {columns[col]}: {pulses[row, col]:.6g} pulses "
                                 f"would be about {shown:.3g} {unit}: not a physical measurement (a lost decimal "
                                 "point?)")


def check_rate(time: np.ndarray, rate_hz: float, where) -> str | None:
    """Compare the time column's mean rate with ``rate_hz``; a warning text, or raise beyond the limit.

    The rate is the least-squares slope of time against sample number; its resolution follows from the
    scatter of the time tags about that line (rounded tags), so a short file with coarse tags is not
    blamed for what it cannot show.
    """
    n = len(time)
    index = np.arange(n, dtype=float) - (n - 1) / 2.0
    slope = float(index @ (time - time.mean()) / (index @ index))
    scatter = time - time.mean() - slope * index
    resolution = float(np.sqrt(np.mean(scatter**2) / (index @ index)))
    deviation = slope * rate_hz - 1.0
    if abs(deviation) <= max(RATE_WARNING, 5.0 * resolution * rate_hz):
        return None
    text = (f"{where}: the time column runs at {1.0 / slope:.9g} Hz, rate_hz says {rate_hz:g} Hz "
            f"({deviation * 1e6:+.3g} ppm); every scale factor would absorb the difference")
    if abs(deviation) > RATE_ERROR_LIMIT:
        raise RecordingError(text + ": correct rate_hz or the time column")
    return text + " (within 100 ppm: calibrated with rate_hz; check which clock is right)"


def validate_schedule(rec: Recording) -> None:
    """Check the segments against each other and against the data; raise :class:`RecordingError`."""
    where = rec.label
    tol = TIME_TOLERANCE * rec.dt
    t_first, t_last = rec.time[0] - rec.dt, rec.time[-1]
    prev: Segment | None = None
    finished_groups: set[int] = set()
    for seg in rec.segments:
        slack = SEGMENT_OVERHANG_S + tol
        if seg.start < t_first - slack or seg.end > t_last + slack:
            raise RecordingError(f"{where}: {seg.describe()} lies outside the data, "
                                 f"which cover {t_first:g}-{t_last:g} s")
        if prev is not None and seg.start < prev.end - tol:
            raise RecordingError(f"{where}: {seg.describe()} overlaps or precedes segment {prev.number} "
                                 f"(ends {prev.end:g} s); segments must be in time order")
        samples = rec.segment_samples(seg)
        if samples.stop - samples.start < 2:
            raise RecordingError(f"{where}: {seg.describe()} holds fewer than two samples")
        new_group = prev is None or seg.group != prev.group
        if new_group:
            if seg.group in finished_groups:
                raise RecordingError(f"{where}: {seg.describe()} returns to group {seg.group}, "
                                     "whose segments must be consecutive")
            if prev is not None:
                _check_group_end(prev, where)
                finished_groups.add(prev.group)
            if not seg.is_static:
                raise RecordingError(f"{where}: {seg.describe()} starts group {seg.group} with a rotation; "
                                     "a group must start with a static segment (its alignment)")
        elif seg.is_static == prev.is_static:
            raise RecordingError(f"{where}: {seg.describe()} follows a {prev.kind} segment; "
                                 "a group must alternate static and rotation segments")
        prev = seg
    _check_group_end(prev, where)
    _check_orientation_chain(rec)


def _check_group_end(seg: Segment, where: str) -> None:
    if not seg.is_static:
        raise RecordingError(f"{where}: {seg.describe()} ends group {seg.group}; "
                             "a group must end with a static segment")


def _check_orientation_chain(rec: Recording) -> None:
    for group in rec.group_ids:
        segs = rec.group_segments(group)
        for before, rot, after in zip(segs[0::2], segs[1::2], segs[2::2]):
            expected = frames.rotate_body(frames.orientation_to_dcm(before.orientation), rot.axis,
                                          np.radians(rot.angle_deg))
            stated = frames.orientation_to_dcm(after.orientation)
            if np.abs(expected - stated).max() > 1e-6:
                try:
                    result = f"gives {frames.dcm_to_orientation(expected, tol_deg=1e-3)}"
                except frames.OrientationError:
                    result = "gives no orientation of the letters N S E W U D"
                raise RecordingError(
                    f"{rec.label}: {after.describe()} does not follow from {before.orientation} and "
                    f"{rot.describe()}: turning {before.orientation} about {rot.axis} by {rot.angle_deg:g} deg "
                    f"{result}"
                )


# --------------------------------------------------------------------------- writing
def description(rec: Recording, data_name: str) -> dict:
    """The TOML description of a recording as a dictionary."""
    site = {"latitude_deg": math.degrees(rec.site.latitude), "height_m": rec.site.height}
    if rec.site.gravity is not None:
        site["gravity_mps2"] = rec.site.gravity
    segments = []
    for seg in rec.segments:
        item = {"group": seg.group, "kind": seg.kind}
        if seg.is_static:
            item["orientation"] = seg.orientation
        else:
            item["axis"] = seg.axis
            item["angle_deg"] = seg.angle_deg
        item["start_s"] = seg.start
        item["end_s"] = seg.end
        segments.append(item)
    return {"format": FORMAT, "name": rec.name, "data": data_name, "site": site,
            "imu": {"rate_hz": rec.rate_hz}, "segments": segments}


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


def _write_samples(path: Path, rec: "Recording") -> Path:
    """The CSV of a recording, written in chunks to a temporary file and renamed when complete."""
    from .io import atomic_open

    with atomic_open(path, "w", encoding="utf-8", newline="") as handle:
        for first in range(0, len(rec.time), CSV_CHUNK):
            handle.write(samples_csv(rec.time, rec.gyro, rec.accel, slice(first, first + CSV_CHUNK),
                                     header=first == 0))
    return path


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"cannot write {value!r} to TOML")
        return repr(value)
    return json.dumps(str(value))  # a JSON string is a valid TOML basic string


def description_toml(rec: Recording, data_name: str) -> str:
    """The TOML description in the layout of the format spec (top keys, [site], [imu], [[segments]])."""
    doc = description(rec, data_name)
    lines = [f"# {FORMAT} recording written by casadi-sins"]
    lines += [f"{key} = {_toml_value(doc[key])}" for key in ("format", "name", "data")]
    for table in ("site", "imu"):
        lines += ["", f"[{table}]"] + [f"{k} = {_toml_value(v)}" for k, v in doc[table].items()]
    for item in doc["segments"]:
        lines += ["", "[[segments]]"] + [f"{k} = {_toml_value(v)}" for k, v in item.items()]
    return "\n".join(lines) + "\n"


def write_recording(rec: Recording, toml_path: str | Path) -> Path:
    """Write ``NAME.toml`` and its CSV (same stem) atomically; returns the TOML path."""
    toml_path = Path(toml_path)
    csv_path = toml_path.with_suffix(".csv")
    _write_samples(csv_path, rec)
    atomic_write_text(toml_path, description_toml(rec, csv_path.name))
    return toml_path
