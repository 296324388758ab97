"""The TOML recording description of ``sins-recording/1``: read a recording, write one.

::

    format = "sins-recording/1"
    name = "kang2013-sim-seed7"
    data = "kang2013-sim-seed7.csv"   # path relative to this file

    [site]
    latitude_deg = 37.5
    height_m = 0.0
    # gravity_mps2 = 9.7997            # optional; default: normal gravity at lat/height

    [imu]
    rate_hz = 100.0

    [conditions]                       # optional, every key optional (data.conditions)
    temperature_c = 23.5
    date = "2024-05-17"

    [[segments]]                       # in time order; kind "static" (orientation) or "rotation" (axis, angle_deg);
                                       # a session by hand leaves them out (a rest at any orientation, a free move)
    group = 1
    kind = "static"
    orientation = "NUE"
    start_s = 0.0
    end_s = 100.0
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..core import orientation as orient
from ..core.earth import Site
from ..core.errors import InputError, OutputError, shown
from ..core.files import write_files
from ..core.toml import array_table_lines, read_toml, read_toml_text, toml_from_bytes
from .conditions import TEMPERATURE_RANGE_C, parse_conditions
from .recording import FORMAT, Recording, Segment, check_physical_range, check_rate, validate_schedule
from .samples import REFERENCE_COLUMNS, read_samples, samples_as_read, samples_writer


#: The longest recording name (it becomes file names and report titles).
MAX_NAME = 200
#: The orientation of a rest at any orientation, when it is written at all (it may be left out).
FREE = "free"


def read_recording(path: str | Path) -> Recording:
    """Read and validate a recording from its TOML description.

    Raises
    ------
    InputError
        With the file and the line or segment of the first problem found.
    """
    path = Path(path)
    head = read_description(path)
    data_path = path.parent / head["data"]
    time, pulses, temperature, reference = read_samples(data_path, head["rate_hz"], with_temperature=True,
                                                        with_reference=True)
    return _checked_recording(head, (time, pulses, temperature, reference), data_path, path, source=path)


def _checked_recording(head: dict, samples: tuple, data_path: Path, path: Path, source) -> Recording:
    """The recording of a description (``path``) and its samples as read (``(time, pulses, temperature,
    reference)`` from ``data_path``), with every check of the format; ``source`` is the recording's source."""
    time, pulses, temperature, reference = samples
    _check_temperature(temperature, data_path)
    _check_reference(reference, data_path)
    rec = Recording(name=head["name"], site=head["site"], rate_hz=head["rate_hz"], segments=head["segments"],
                    time=time, gyro=pulses[:, :3], accel=pulses[:, 3:], source=source, warnings=head["warnings"],
                    conditions=head["conditions"], temperature=temperature,
                    reference=None if reference is None else np.radians(reference))
    rate_warning = check_rate(time, head["rate_hz"], data_path)
    if rate_warning:
        rec.warnings.append(rate_warning)
    if not rec.segments:  # the format allows no [[segments]]: the schedule is found from the samples
        from .segmentation import segment_recording  # noqa: PLC0415 (the search loads only when it is needed)

        try:
            found, notes = segment_recording(time, rec.gyro, rec.accel, rec.rate_hz, rec.site, rec.name)
        except InputError as exc:
            raise InputError(path, f"no [[segments]], and none found in the samples: {exc.reason}") from None
        rec.segments = found.segments
        rec.notes = [f"{path}: no [[segments]]: the schedule was found from the samples"] + notes
    validate_schedule(rec)
    check_physical_range(rec, data_path)
    return rec


def as_read(rec: Recording, toml_path: str | Path) -> Recording:
    """``rec`` as :func:`read_recording` would read it back once written as ``toml_path`` (and its CSV): the
    description and the samples are made in memory (a chunk of the CSV at a time) and go through the same
    readers and checks, so that a recording is written only when it can be read.  Nothing is written.

    Raises
    ------
    InputError
        What the reader would refuse, naming the file to be written (and its line).
    """
    toml_path, csv_path = recording_paths(toml_path)
    try:
        text = description_toml(rec, csv_path.name)
    except ValueError as exc:  # a number TOML cannot hold (nan, inf)
        raise InputError(toml_path, str(exc)) from None
    head = description_from_text(text.encode("utf-8"), toml_path)
    return _checked_recording(head, samples_as_read(rec, csv_path), csv_path, toml_path, source=None)


def read_description(path: str | Path, require_segments: bool = True) -> dict:
    """The description alone (no samples): ``name``, ``data``, ``site``, ``rate_hz``, ``segments``,
    ``conditions`` and ``warnings``; each problem an :class:`InputError` naming the file and line.
    Without ``require_segments`` a description with no ``[[segments]]`` has none (``noise``: all at rest)."""
    path = Path(path)
    doc, text = read_toml_text(path, "recording description")
    return _description(doc, text, path, require_segments)


def description_from_text(raw: bytes, path: str | Path) -> dict:
    """:func:`read_description` of a description's bytes made in memory (``path`` names them in messages)."""
    doc, text = toml_from_bytes(raw, path, "recording description")
    return _description(doc, text, Path(path))


def _description(doc: dict, text: str, path: Path, require_segments: bool = True) -> dict:
    """The checked content of a description's TOML (:func:`read_description`)."""
    if doc.get("format") != FORMAT:
        raise InputError(path, f"format must be {FORMAT!r}, found {shown(doc.get('format'))}")
    name = _require(doc, "name", str, path)
    if not name or len(name) > MAX_NAME or not name.isprintable():
        raise InputError(path, f"'name' must be one line of 1 to {MAX_NAME} printable characters, found "
                         f"{shown(name)}")
    data_name = _require(doc, "data", str, path)
    if not data_name.strip():
        raise InputError(path, "'data' is empty; it must name the CSV of samples")
    site = _parse_site(doc.get("site"), path)
    imu = doc.get("imu")
    if not isinstance(imu, dict):
        raise InputError(path, "missing [imu] table with rate_hz")
    rate_hz = _number(imu.get("rate_hz"), path, "[imu] rate_hz")
    if not 1.0 <= rate_hz <= 1e5:
        raise InputError(path, f"[imu] rate_hz must be between 1 and 100000 Hz, found {rate_hz:g}")
    segments = ([] if not require_segments and "segments" not in doc
                else _parse_segments(doc.get("segments"), path, array_table_lines(text, "segments")))
    conditions, notes = parse_conditions(doc.get("conditions"), path)
    return {"name": name, "data": data_name, "site": site, "rate_hz": rate_hz, "segments": segments,
            "conditions": conditions, "warnings": notes}


def _check_reference(reference, data_path) -> None:
    """Reference attitude angles within their ranges: roll and heading within +/-360 deg, pitch within +/-90 deg."""
    if reference is None:
        return
    for j, (name, limit) in enumerate(zip(REFERENCE_COLUMNS, (360.0, 90.0, 360.0))):
        beyond = np.flatnonzero(np.abs(reference[:, j]) > limit)
        if len(beyond):
            raise InputError(data_path, f"{name} {reference[beyond[0], j]:g} is beyond +/-{limit:g} deg",
                             line=int(beyond[0]) + 2)


def _check_temperature(temperature, data_path) -> None:
    """The CSV's temperature column within the range of a unit on a bench, else name the line."""
    if temperature is None:
        return
    low, high = TEMPERATURE_RANGE_C
    outside = (temperature < low) | (temperature > high)
    if outside.any():
        row = int(np.argmax(outside))
        raise InputError(data_path, f"temperature {temperature[row]:g} is outside {low:g}..{high:g} degC "
                         "(the column is degC)", line=row + 2, column="temperature")


def _require(doc: dict, key: str, kind: type, path) -> object:
    value = doc.get(key)
    if not isinstance(value, kind):
        raise InputError(path, f"missing or invalid {key!r} (expected {kind.__name__})")
    return value


def _number(value, path, what: str, line: int | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        found = "nothing" if value is None else shown(value)
        raise InputError(path, f"{what} must be a finite number, found {found}", line=line)
    return float(value)


def _parse_site(site, path: Path) -> Site:
    if not isinstance(site, dict):
        raise InputError(path, "missing [site] table with latitude_deg and height_m")
    lat = _number(site.get("latitude_deg"), path, "[site] latitude_deg")
    if not -90.0 <= lat <= 90.0:
        raise InputError(path, f"[site] latitude_deg {lat:g} is outside -90..90")
    height = _number(site.get("height_m"), path, "[site] height_m")
    if not -500.0 <= height <= 10000.0:
        raise InputError(path, f"[site] height_m {height:g} is outside -500..10000 m (a test site on the ground)")
    gravity = site.get("gravity_mps2")
    if gravity is not None:
        gravity = _number(gravity, path, "[site] gravity_mps2")
        if not 9.7 < gravity < 9.9:
            raise InputError(path, f"[site] gravity_mps2 {gravity:g} is not a gravity on Earth (9.7..9.9)")
    return Site(latitude=math.radians(lat), height=height, gravity=gravity)


def _parse_segments(items, path: Path, lines: list[int]) -> list[Segment]:
    if items is None:
        return []  # no schedule: it is to be found from the samples (read_recording)
    if not isinstance(items, list) or not items:
        raise InputError(path, "[[segments]] must be an array of tables (or left out: the schedule is then found "
                               "from the samples)")
    return [_parse_segment(item, number, path, lines[number - 1] if number <= len(lines) else None)
            for number, item in enumerate(items, start=1)]


def _parse_segment(item, number: int, path: Path, line: int | None) -> Segment:
    """One ``[[segments]]`` table; errors name the segment and the line of its header."""

    def fail(message):
        return InputError(path, f"segment {number}: {message}", line=line)

    if not isinstance(item, dict):
        raise fail("not a table")
    group = item.get("group")
    if isinstance(group, bool) or not isinstance(group, int):
        raise fail(f"'group' must be an integer, found {shown(group)}")
    kind = item.get("kind")
    start = _number(item.get("start_s"), path, f"segment {number}: start_s", line)
    end = _number(item.get("end_s"), path, f"segment {number}: end_s", line)
    if end <= start:
        raise fail(f"end_s {end:g} is not after start_s {start:g}")
    if kind == "static":
        orientation = item.get("orientation")
        if orientation is None or (isinstance(orientation, str) and orientation.lower() == FREE):
            return Segment(number, group, kind, start, end)  # a rest at any orientation (a session by hand)
        if not isinstance(orientation, str) or orientation != orientation.upper():
            raise fail(f"orientation {shown(orientation)} must be three capital letters of N S E W U D")
        try:
            orient.orientation_to_dcm(orientation)
        except orient.OrientationError as exc:
            raise fail(str(exc)) from None
        return Segment(number, group, kind, start, end, orientation=orientation)
    if kind == "rotation":
        axis = item.get("axis")
        if axis is None and item.get("angle_deg") is None:
            return Segment(number, group, kind, start, end)  # a free move: only that the unit moved
        if axis is None or item.get("angle_deg") is None:
            raise fail("a rotation gives both 'axis' and 'angle_deg', or neither (a free move by hand)")
        try:
            orient.parse_axis(axis)
        except orient.OrientationError as exc:
            raise fail(str(exc)) from None
        angle = _number(item.get("angle_deg"), path, f"segment {number}: angle_deg", line)
        if angle == 0.0:
            raise fail("angle_deg must not be zero")
        return Segment(number, group, kind, start, end, axis=axis, angle_deg=angle)
    raise fail(f"kind must be 'static' or 'rotation', found {shown(kind)}")


def description(rec: Recording, data_name: str) -> dict:
    """The TOML description of a recording as a dictionary."""
    site = {"latitude_deg": math.degrees(rec.site.latitude), "height_m": rec.site.height}
    if rec.site.gravity is not None:
        site["gravity_mps2"] = rec.site.gravity
    segments = []
    for seg in rec.segments:
        item = {"group": seg.group, "kind": seg.kind}
        if seg.is_free:
            pass  # a rest at any orientation, a free move: the format leaves the keys out
        elif seg.is_static:
            item["orientation"] = seg.orientation
        else:
            item["axis"] = seg.axis
            item["angle_deg"] = seg.angle_deg
        item["start_s"] = seg.start
        item["end_s"] = seg.end
        segments.append(item)
    doc = {"format": FORMAT, "name": rec.name, "data": data_name, "site": site,
           "imu": {"rate_hz": rec.rate_hz}, "segments": segments}
    if rec.conditions:
        doc["conditions"] = rec.conditions.to_dict()
    return doc


def toml_value(value) -> str:
    """A value as TOML text (strings as JSON strings: a JSON string is a valid TOML basic string)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"cannot write {value!r} to TOML")
        return repr(value)
    return json.dumps(str(value))


def description_toml(rec: Recording, data_name: str) -> str:
    """The TOML description in the layout of the format (top keys, [site], [imu], [[segments]])."""
    doc = description(rec, data_name)
    lines = [f"# {FORMAT} recording written by casadi-sins"]
    lines += [f"{key} = {toml_value(doc[key])}" for key in ("format", "name", "data")]
    for table in ("site", "imu", "conditions"):
        if table not in doc:
            continue
        lines += ["", f"[{table}]"] + [f"{k} = {toml_value(v)}" for k, v in doc[table].items()]
    for item in doc["segments"]:
        lines += ["", "[[segments]]"] + [f"{k} = {toml_value(v)}" for k, v in item.items()]
    return "\n".join(lines) + "\n"


def recording_paths(toml_path: str | Path) -> list[Path]:
    """``[NAME.toml, NAME.csv]``: the description to write and its samples beside it.

    Raises
    ------
    OutputError
        When ``toml_path`` is not a ``.toml`` name (``rec.csv`` would be the description and the samples at
        once).
    """
    toml_path = Path(toml_path)
    if toml_path.suffix.lower() != ".toml":
        raise OutputError(f"{toml_path}: a recording is written as a description NAME.toml with its samples "
                          "NAME.csv beside it; give the description's name (NAME.toml)")
    return [toml_path, toml_path.with_suffix(".csv")]


def recording_files(rec: Recording, toml_path: str | Path) -> dict:
    """``{path: content}`` of a recording: ``NAME.toml`` and its CSV (same stem), for :func:`write_files`."""
    toml_path, csv_path = recording_paths(toml_path)
    return {csv_path: samples_writer(rec), toml_path: description_toml(rec, csv_path.name).encode("utf-8")}


def write_recording(rec: Recording, toml_path: str | Path) -> Path:
    """Write ``NAME.toml`` and its CSV (same stem) together; returns the TOML path."""
    write_files(recording_files(rec, toml_path))
    return Path(toml_path)


def is_recording_description(path) -> bool:
    """Whether a TOML file is a recording description (``format = "sins-recording/..."``), not a problem file,
    a sheet or another kind of TOML.

    Raises
    ------
    InputError
        When the file cannot be read as TOML.
    """
    return str(read_toml(path, "problem file or recording description").get("format", "")).startswith(
        FORMAT.split("/")[0])
