"""Where a parameter table comes from: its companion report, read back.

``calibrate`` writes ``NAME.report.json`` beside every table ``NAME.csv`` (:mod:`report.calibration`):
the unit id, the date of the calibration, the SHA-256 of the recording, the solver and the versions
of the software.  The table itself stays ``parameter,unit,value,sigma``; whatever needs its
provenance (an export, the history of a unit, a resumed batch) reads it here.  A table without a
companion report keeps what can be known: its own hash and the file's modification date, flagged as
such.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
from pathlib import Path

from ..core.errors import InputError
from ..core.inputs import check_input_file
from ..core.text import one_line
from ..core.files import file_sha256
from ..data.conditions import DATE_YEARS, check_year, parse_date
from ..data.thermal import companion_path as thermal_companion
from .calibration import companion_paths

#: A table or a report larger than this is not one (they are kilobytes).
MAX_REPORT_BYTES = 50_000_000


@dataclasses.dataclass
class Provenance:
    """What is known of a parameter table's origin.

    Attributes
    ----------
    table : Path
        The parameter table.
    table_sha256 : str
        SHA-256 of the table file.
    date : datetime.datetime
        When the calibration was made (the report's ``created``), or the table file's modification
        time when there is no report (``from_report`` False).
    unit_id, recording, recording_sha256, solver, software : str or None
        From the companion report.
    versions : dict
        Versions of the software that calibrated (empty for reports that predate them).
    conditions : dict
        The recording conditions of the report (``temperature_c``, ``date``, ``operator``, ``bench``,
        ``unit_id``; empty when none were given or the report predates them).
    from_report : bool
        Whether a companion report was found.
    """

    table: Path
    table_sha256: str
    date: datetime.datetime
    unit_id: str | None = None
    recording: str | None = None
    recording_sha256: str | None = None
    solver: str | None = None
    software: str | None = None
    versions: dict = dataclasses.field(default_factory=dict)
    from_report: bool = False
    conditions: dict = dataclasses.field(default_factory=dict)

    @property
    def recorded(self) -> datetime.datetime | None:
        """When the recording was made (its conditions' date), or None."""
        date = self.conditions.get("date")
        try:
            return None if date is None else parse_date(date)
        except ValueError:
            return None

    def metadata(self) -> dict:
        """The provenance as the metadata block of an export (no empty entries)."""
        out = {"unit_id": self.unit_id, "table": str(self.table), "table_sha256": self.table_sha256,
               "calibrated": self.date.isoformat(timespec="seconds") if self.from_report else None,
               "recording": self.recording, "recording_sha256": self.recording_sha256, "solver": self.solver,
               "calibrated_with": self.software,
               "versions": ", ".join(f"{k} {v}" for k, v in self.versions.items()) or None}
        out.update(conditions_metadata(self.conditions))
        if not self.from_report:
            out["provenance"] = "no companion report beside the table: unit, date and recording unknown"
        return {k: v for k, v in out.items() if v is not None}


def conditions_metadata(conditions: dict) -> dict:
    """Recording conditions as entries of an export's metadata block (``recording_date``, ``temperature_c``,
    ``operator``, ``bench``, ``recording_unit_id``)."""
    return {f"recording_{k}" if k in ("date", "unit_id") else k: v for k, v in conditions.items()
            if k != "temperature_source"}


def read_provenance(table_path: str | Path) -> Provenance:
    """The provenance of a parameter table from its companion ``NAME.report.json`` (when present).

    Raises
    ------
    InputError
        When the table cannot be read, or its companion report exists but is not a calibration report.
    """
    table = Path(table_path)
    check_input_file(table, "parameter table", max_bytes=MAX_REPORT_BYTES)
    try:
        table_hash = file_sha256(table)
        mtime = table.stat().st_mtime
    except FileNotFoundError:
        raise InputError(table, "no such parameter table") from None
    except IsADirectoryError:
        raise InputError(table, "is a folder, not a parameter table") from None
    report = companion_paths(table)[0]
    if not (report.exists() or report.is_symlink()):
        date = datetime.datetime.fromtimestamp(mtime, datetime.timezone.utc)
        return Provenance(table, table_hash, date)
    check_input_file(report, "calibration report", max_bytes=MAX_REPORT_BYTES)
    try:
        data = json.loads(report.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, RecursionError, json.JSONDecodeError) as exc:
        raise InputError(report, f"companion report of {one_line(table.name)} cannot be read "
                         f"({one_line(exc)})") from None
    if not isinstance(data, dict) or not str(data.get("format", "")).startswith("casadi-sins-report/"):
        raise InputError(report, "not a casadi-sins calibration report (format casadi-sins-report/1)")
    try:
        date = datetime.datetime.fromisoformat(str(data.get("created")))
    except ValueError:
        raise InputError(report, f"'created' {one_line(repr(data.get('created')), 60)} is not an ISO date") from None
    if date.tzinfo is None:
        date = date.replace(tzinfo=datetime.timezone.utc)
    if not EARLIEST_YEAR <= date.year < LATEST_YEAR:
        raise InputError(report, f"'created' {one_line(repr(data.get('created')), 60)} is not a date of a "
                         f"calibration (years {EARLIEST_YEAR} to {LATEST_YEAR - 1})")
    rec = data.get("recording") if isinstance(data.get("recording"), dict) else {}
    versions = data.get("versions") if isinstance(data.get("versions"), dict) else {}
    recorded = _conditions(data).get("date")
    try:
        check_year(parse_date(recorded)) if recorded is not None else None
    except ValueError as exc:
        if "years" in str(exc):
            raise InputError(report, f"conditions.date: {exc}") from None
    return Provenance(table, table_hash, date, _text(data.get("unit_id")) or _text(_conditions(data).get("unit_id")),
                      _text(rec.get("name")), _text(rec.get("sha256")), _text(data.get("solver")),
                      _text(data.get("software")), {str(k): str(v) for k, v in versions.items()}, from_report=True,
                      conditions=_conditions(data))


def _conditions(data: dict) -> dict:
    """The report's conditions: numbers as numbers, anything else as one line of text."""
    raw = data.get("conditions") if isinstance(data.get("conditions"), dict) else {}
    return {str(k): (v if isinstance(v, (int, float)) and not isinstance(v, bool) else one_line(v))
            for k, v in raw.items() if v is not None}


#: Calibration dates outside these years are no calibration's (and 9999-12-31 overflows date arithmetic).
EARLIEST_YEAR, LATEST_YEAR = DATE_YEARS


def _text(value) -> str | None:
    return None if value is None else one_line(value)


def thermal_provenance(thermal_csv: str | Path) -> dict:
    """The provenance of a thermal model (``thermal.csv`` and its companion ``thermal.json``) as the metadata
    block of an export: the unit id, both files' SHA-256, when and by what software the model was fitted, the
    versions, and per calibration its temperature, table and recording SHA-256 and date.  A companion written
    before these were recorded gives what it has (``provenance`` says what is missing).

    Raises
    ------
    InputError
        When the model file cannot be read, or its companion exists but is not JSON.
    """
    csv_path = Path(thermal_csv)
    check_input_file(csv_path, "thermal model", max_bytes=MAX_REPORT_BYTES)
    out = {"thermal_model": str(csv_path), "thermal_model_sha256": file_sha256(csv_path)}
    json_path = thermal_companion(csv_path)
    if not json_path.is_file():
        out["provenance"] = "no companion thermal.json: covariance, dates and calibrations unknown"
        return out
    check_input_file(json_path, "thermal model companion", max_bytes=MAX_REPORT_BYTES)
    try:
        data = json.loads(json_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, RecursionError, json.JSONDecodeError) as exc:
        raise InputError(json_path, f"cannot be read ({one_line(exc)})") from None
    data = data if isinstance(data, dict) else {}
    versions = data.get("versions") if isinstance(data.get("versions"), dict) else {}
    out.update({"unit_id": _text(data.get("unit_id")), "thermal_covariance_sha256": file_sha256(json_path),
                "fitted": _text(data.get("created")), "fitted_with": _text(data.get("software")),
                "versions": ", ".join(f"{one_line(k)} {one_line(v)}" for k, v in versions.items()) or None})
    calibrations = data.get("calibrations") if isinstance(data.get("calibrations"), list) else []
    for k, cal in enumerate(c for c in calibrations if isinstance(c, dict)):
        parts = [f"{cal.get('temperature_c')} degC", f"table {one_line(cal.get('table'), 120)}"]
        parts += [f"{word} {one_line(cal[key], 80)}" for key, word in (
            ("table_sha256", "sha256"), ("recording_sha256", "recording sha256"), ("calibrated", "calibrated"),
            ("calibrated_with", "with")) if cal.get(key)]
        out[f"calibration_{k + 1}"] = "; ".join(parts)
    if not data.get("created"):
        out["provenance"] = "thermal.json written before the fit's date and versions were recorded"
    return {k: v for k, v in out.items() if v is not None}
