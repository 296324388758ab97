"""A calibration's record: the parameter table ``NAME.csv`` and its companion report ``NAME.report.json``.

The table holds the values and sigma (:mod:`data.tables`); the report beside it (format
``casadi-sins-report/1``, written by ``calibrate``, ``batch`` and ``thermal``) holds what the table cannot:
the full covariance (SI, the table's order), the provenance (software identity and versions, date, unit id,
the recording's name and SHA-256, the table's SHA-256 as written), the recording conditions, the
acceptance verdict with its reasons, the warnings, and the calibration's details (noise, checks, solver).
This module is the one place that writes those keys and reads them back: :class:`CalibrationRecord` and
:func:`read_record` for the readers (``export``, ``apply``, ``history``, ``thermal``, ``modulate``,
``batch``), :meth:`CalibrationRecord.of_calibration` and :meth:`CalibrationRecord.report_json` for the writers.

A table without a report is a record without covariance and with what its file tells (its SHA-256 and
modification date, flagged as such).  A report that is not JSON, too large or not a file is one
:class:`core.errors.InputError` naming it.  The parts of a report are checked as a reader asks for them:
a hand-made report holding only a covariance still weighs its table (:attr:`CalibrationRecord.parameters`),
while the provenance (:attr:`CalibrationRecord.provenance`) asks for a dated ``casadi-sins-report/1``.
"""

from __future__ import annotations

import dataclasses
import datetime
import functools
import json
import math
from pathlib import Path

import numpy as np

from ..core.errors import InputError, shown
from ..core.files import file_sha256
from ..core.inputs import check_input_file
from ..core.text import one_line
from ..core.version import build_identity, software_versions
from ..model.parameters import ParameterSet, truth_errors
from ..model.registry import natural_unit_of, natural_value_of, unit_of
from .conditions import DATE_YEARS, check_year, parse_date
from .tables import read_table

#: The format of a calibration report (its ``"format"`` key).
REPORT_FORMAT = "casadi-sins-report/1"
#: The key of the report holding the SHA-256 of its table as written (``batch`` resumes on it).
TABLE_SHA256_KEY = "table_sha256"
#: A table or a report larger than this is not one (they are kilobytes).
MAX_REPORT_BYTES = 50_000_000
#: Calibration dates outside these years are no calibration's (and 9999-12-31 overflows date arithmetic).
EARLIEST_YEAR, LATEST_YEAR = DATE_YEARS


def companion_paths(table_path: str | Path) -> tuple[Path, Path]:
    """``NAME.report.json`` and ``NAME.report.md`` beside a parameter table ``NAME.csv``."""
    table_path = Path(table_path)
    stem = table_path.with_suffix("")
    return stem.with_name(stem.name + ".report.json"), stem.with_name(stem.name + ".report.md")


def report_path(table_path: str | Path) -> Path:
    """``NAME.report.json`` beside a parameter table ``NAME.csv``."""
    return companion_paths(table_path)[0]


# ---------------------------------------------------------------------------------------------------------------
# Writing


def parameter_rows(params: ParameterSet, truth: ParameterSet | None = None) -> list[dict]:
    """The report's ``"parameters"``: one row per parameter, SI value and sigma, natural value and sigma, and
    the error against a truth (``error_natural``, ``error_over_sigma``; None where the truth lacks it)."""
    sigma = params.natural_sigma()
    errors = truth_errors(params, truth) if truth is not None else None
    rows = []
    for i, name in enumerate(params.names):
        value, unit = natural_value_of(name, params.values[i])
        row = {"parameter": name, "unit": unit_of(name), "value": float(params.values[i]),
               "sigma": None if params.sigma is None else float(params.sigma[i]),
               "value_natural": value, "value_unit": unit, "sigma_natural": float(sigma[i]),
               "sigma_unit": natural_unit_of(name)}
        if errors is not None:
            err = float(errors[i])
            if not math.isfinite(err):  # the truth file does not give this parameter
                row.update(error_natural=None, error_over_sigma=None)
            else:
                row.update(error_natural=err, error_over_sigma=err / float(sigma[i]) if sigma[i] > 0 else math.nan)
        rows.append(row)
    return rows


def identity(created: str | None = None) -> dict:
    """The head of a report: its format, the software's identity and versions, and when it was made (now,
    ISO 8601 in UTC, unless ``created`` is given)."""
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    return {"format": REPORT_FORMAT, "software": build_identity(), "created": created or now,
            "versions": software_versions()}


def report_bytes(data: dict) -> bytes:
    """A report's JSON file (indented, NumPy numbers as plain ones, anything else as text)."""
    return (json.dumps(data, indent=2, default=_json_default) + "\n").encode()


def _json_default(value):
    """NumPy values in JSON."""
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.bool_,)):
        return bool(value)
    return str(value)


# ---------------------------------------------------------------------------------------------------------------
# Reading


def parse_report(content: bytes | str, path: str | Path) -> dict:
    """A report's JSON content as a dict.

    Raises
    ------
    InputError
        Naming ``path`` when the content is not JSON text of an object.
    """
    try:
        data = json.loads(content)
    except (UnicodeDecodeError, RecursionError, ValueError) as exc:
        raise InputError(path, f"not a JSON calibration report ({shown(one_line(exc), 120)})") from None
    if not isinstance(data, dict):
        raise InputError(path, f"not a JSON calibration report (a {type(data).__name__}, not an object)")
    return data


def read_report(table_path: str | Path) -> dict | None:
    """The companion report of a parameter table as a dict, None when there is none.

    Raises
    ------
    InputError
        Naming the report when it is not a regular readable file, too large or not JSON of an object.
    """
    path = report_path(table_path)
    if not (path.exists() or path.is_symlink()):
        return None
    check_input_file(path, "calibration report", max_bytes=MAX_REPORT_BYTES)
    try:
        content = path.read_bytes()
    except OSError as exc:
        raise InputError(path, f"cannot be read ({one_line(exc)})") from None
    return parse_report(content, path)


def read_record(table_path: str | Path) -> "CalibrationRecord":
    """The record of a parameter table: the table (:func:`data.tables.read_table`), its file's SHA-256 and date,
    and its companion report when there is one.

    Raises
    ------
    InputError
        Naming the table or the report that cannot be read (:func:`read_report`).
    """
    return _record(Path(table_path), read_table(table_path))


def read_provenance(table_path: str | Path) -> "Provenance":
    """Where a table comes from (:attr:`CalibrationRecord.provenance`), the table itself not parsed: any file
    ``NAME.csv`` (a parameter table, a thermal model) with or without its companion report.

    Raises
    ------
    InputError
        When the file cannot be read, or its companion report exists but is not a calibration report.
    """
    table = Path(table_path)
    check_input_file(table, "parameter table", max_bytes=MAX_REPORT_BYTES)
    return _record(table, None).provenance


def _record(table: Path, params: ParameterSet | None) -> "CalibrationRecord":
    try:
        digest, mtime = file_sha256(table), table.stat().st_mtime
    except OSError as exc:
        raise InputError(table, f"cannot be read ({one_line(exc)})") from None
    report = read_report(table)
    return CalibrationRecord(params, table=table, report=report or {}, from_report=report is not None,
                             file_sha256=digest, file_date=datetime.datetime.fromtimestamp(mtime, datetime.timezone.utc))


def _text(value) -> str | None:
    return None if value is None else one_line(value)


def _mapping(data: dict, key: str) -> dict:
    value = data.get(key)
    return value if isinstance(value, dict) else {}


def _conditions(data: dict) -> dict:
    """The report's conditions: numbers as numbers, anything else as one line of text."""
    return {str(k): (v if isinstance(v, (int, float)) and not isinstance(v, bool) else one_line(v))
            for k, v in _mapping(data, "conditions").items() if v is not None}


def conditions_metadata(conditions: dict) -> dict:
    """Recording conditions as entries of an export's metadata block (``recording_date``, ``temperature_c``,
    ``operator``, ``bench``, ``recording_unit_id``)."""
    return {f"recording_{k}" if k in ("date", "unit_id") else k: v for k, v in conditions.items()
            if k != "temperature_source"}


def check_psd(cov: np.ndarray, path) -> None:
    """Refuse a covariance that is not symmetric positive semi-definite.

    Raises
    ------
    InputError
        Naming ``path``.
    """
    if not np.allclose(cov, cov.T, rtol=1e-9, atol=0.0):
        raise InputError(path, "the covariance is not symmetric")
    eig = np.linalg.eigvalsh(cov)
    if eig.min() < -1e-9 * max(eig.max(), 0.0):
        raise InputError(path, f"the covariance is not positive semi-definite (smallest eigenvalue {eig.min():.3g})")


def report_covariance(data: dict, names, path) -> np.ndarray | None:
    """The ``"covariance"`` of a report over the parameters ``names`` (SI, their order), None when it has none.

    Raises
    ------
    InputError
        Naming ``path`` when it is not an n x n list of finite numbers.
    """
    if data.get("covariance") is None:
        return None
    raw, n = data["covariance"], len(names)
    if not (isinstance(raw, list) and len(raw) == n and all(isinstance(r, list) and len(r) == n for r in raw)):
        raise InputError(path, f"\"covariance\" must be a list of {n} lists of {n} numbers (the table's parameters)")
    if any(isinstance(x, bool) or not isinstance(x, (int, float)) for r in raw for x in r):
        raise InputError(path, "\"covariance\" has an entry that is not a number")
    matrix = np.array(raw, dtype=float)
    if not np.all(np.isfinite(matrix)):
        raise InputError(path, "\"covariance\" has non-finite entries")
    return matrix


def _created(data: dict, path) -> datetime.datetime:
    """The report's ``created`` as an aware date of a calibration."""
    text = repr(data.get("created"))
    try:
        date = datetime.datetime.fromisoformat(str(data.get("created")))
    except ValueError:
        raise InputError(path, f"'created' {one_line(text, 60)} is not an ISO date") from None
    if date.tzinfo is None:
        date = date.replace(tzinfo=datetime.timezone.utc)
    if not EARLIEST_YEAR <= date.year < LATEST_YEAR:
        raise InputError(path, f"'created' {one_line(text, 60)} is not a date of a calibration (years "
                         f"{EARLIEST_YEAR} to {LATEST_YEAR - 1})")
    return date


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
    from_report : bool
        Whether a companion report was found.
    conditions : dict
        The recording conditions of the report (``temperature_c``, ``date``, ``operator``, ``bench``,
        ``unit_id``; empty when none were given or the report predates them).
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


@dataclasses.dataclass
class CalibrationRecord:
    """A calibration's record: its parameter table and what its companion report says of it.

    Attributes
    ----------
    table_parameters : ParameterSet or None
        The table as read (values and sigma), None for a record known only from its report.
    table : Path or None
        Where the table is (None before it is written).
    report : dict
        The companion report as read or to be written (empty without one); the properties below read it.
    from_report : bool
        Whether a companion report was found (or is to be written).
    file_sha256 : str or None
        SHA-256 of the table file as it is now (None before it is written).
    file_date : datetime.datetime or None
        The table file's modification time (the date of a table without a report).

    Examples
    --------
    >>> record = read_record("unit42.csv")                       # doctest: +SKIP
    >>> record.parameters.covariance                             # the report's, or None  # doctest: +SKIP
    >>> record.provenance.recording_sha256, record.verdict        # doctest: +SKIP
    """

    table_parameters: ParameterSet | None
    table: Path | None = None
    report: dict = dataclasses.field(default_factory=dict)
    from_report: bool = True
    file_sha256: str | None = None
    file_date: datetime.datetime | None = None

    @classmethod
    def of_calibration(cls, parameters: ParameterSet, *, solver: str, unit_id: str | None = None,
                       recording: dict | None = None, conditions: dict | None = None, warnings=(),
                       details: dict | None = None, verdict: str | None = None, acceptance: dict | None = None,
                       truth: ParameterSet | None = None, command: str | None = None,
                       created: str | None = None) -> "CalibrationRecord":
        """The record of a calibration about to be written (not yet beside a table: :meth:`with_table`).

        Parameters
        ----------
        parameters : ParameterSet
            The table, with its covariance when known.
        solver : str
            ``"nlp"``, ``"ils"`` (or what made the table, ``"thermal"``).
        unit_id : str, optional
        recording : dict, optional
            The recording calibrated: ``name``, ``source``, ``sha256`` and what else describes it.
        conditions : dict, optional
            Its recording conditions (:func:`data.conditions.conditions_dict`).
        warnings : sequence of str
        details : dict, optional
            Every other key of the report (noise, checks, solver status), in the order to write them.
        verdict, acceptance : optional
            ``"pass"`` or ``"fail"`` against a tolerance sheet, and the acceptance block (reasons, sheet).
        truth : ParameterSet, optional
            A truth file: each parameter's error against it in the report's rows.
        command, created : str, optional
            The command line, and the report's date (default: now).
        """
        report = identity(created)
        if command is not None:
            report["command"] = command
        report["unit_id"] = unit_id
        if recording is not None:
            report["recording"] = dict(recording)
        report.update(conditions=dict(conditions or {}), solver=solver, warnings=list(warnings))
        report.update(details or {})
        report["parameters"] = parameter_rows(parameters, truth)
        report["covariance"] = (None if parameters.covariance is None
                                else [[float(x) for x in row] for row in parameters.covariance])  # SI, table order
        if verdict is not None:
            report["verdict"] = verdict
            report["acceptance"] = dict(acceptance or {})
        return cls(parameters, report=report, from_report=True)

    @classmethod
    def of_report(cls, data: dict, table: str | Path | None = None) -> "CalibrationRecord":
        """The record a report tells of alone (its table not read: its parameters from the report's rows)."""
        return cls(None, table=None if table is None else Path(table), report=data, from_report=True)

    # -- what the report says ----------------------------------------------------------------------------------

    @property
    def conditions(self) -> dict:
        """The recording conditions (numbers as numbers, anything else one line of text; empty when none)."""
        return _conditions(self.report)

    @property
    def unit_id(self) -> str | None:
        """The unit id: the report's (``--unit-id``), else that of the recording's conditions."""
        return _text(self.report.get("unit_id")) or _text(self.conditions.get("unit_id"))

    @property
    def recording_sha256(self) -> str | None:
        """The SHA-256 of the recording that was calibrated (TOML and data), None when unknown."""
        return _text(_mapping(self.report, "recording").get("sha256"))

    @property
    def stored_table_sha256(self) -> str | None:
        """The SHA-256 of the table as it was written, as the report names it."""
        return self.report.get(TABLE_SHA256_KEY)

    @property
    def verdict(self) -> str | None:
        """``"pass"`` or ``"fail"`` against a tolerance sheet, None when the table was not judged."""
        return self.report.get("verdict") or None

    @property
    def acceptance(self) -> dict:
        """The acceptance block (``reasons``, ``sheet``, ``sheet_sha256``, ``judged``); empty when not judged."""
        return _mapping(self.report, "acceptance")

    @property
    def reasons(self) -> list[str]:
        """Why the table failed its sheet (empty when it passed or was not judged)."""
        return [str(r) for r in self.acceptance.get("reasons") or []] if self.verdict == "fail" else []

    @property
    def warnings(self) -> list[str]:
        """The calibration's warnings."""
        return [str(w) for w in self.report.get("warnings") or []]

    @property
    def wall_time_s(self) -> float:
        """How long the calibration took (s; NaN when unknown)."""
        return self.report.get("wall_time_s", math.nan)

    @property
    def temperature_c(self) -> float | None:
        """The temperature (degC) of the recording conditions, None when the report gives none.

        Raises
        ------
        InputError
            Naming the report when it is not a finite number.
        """
        value = self.conditions.get("temperature_c")
        if value is None:
            return None
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(self.report_path, f"conditions.temperature_c {shown(value)} is not a number")
        return float(value)

    @property
    def report_path(self) -> Path | None:
        """The companion report's path (None for a record without a table path)."""
        return None if self.table is None else report_path(self.table)

    # -- the table with what the report adds ---------------------------------------------------------------------

    @functools.cached_property
    def covariance(self) -> np.ndarray | None:
        """The report's covariance of the table's parameters (SI, the table's order), None when it has none.

        Raises
        ------
        InputError
            Naming the report when it is no n x n matrix of finite numbers, not symmetric positive
            semi-definite, or its diagonal is not the square of the table's sigma (where the table has one).
        """
        names = self._names()
        cov = report_covariance(self.report, names, self.report_path)
        if cov is None or self.table_parameters is None:
            return cov
        check_psd(cov, self.report_path)
        sigma = self.table_parameters.sigma
        if sigma is not None:
            known = np.isfinite(sigma)
            if not np.allclose(np.sqrt(np.clip(np.diag(cov), 0.0, None))[known], sigma[known], rtol=1e-3, atol=0.0):
                raise InputError(self.report_path, f"its covariance's diagonal does not match the sigma of {self.table}")
        return cov

    @property
    def parameters(self) -> ParameterSet:
        """The table with the report's covariance when it gives one (its sigma column alone else); for a
        record known only from its report, the report's rows (SI values and sigma)."""
        if self.table_parameters is None:
            rows = self._rows()
            sigma = [math.nan if p.get("sigma") is None else p["sigma"] for p in rows]
            return ParameterSet(np.array([p["value"] for p in rows], dtype=float), sigma=np.array(sigma, dtype=float),
                                names=tuple(p["parameter"] for p in rows))
        params, cov = self.table_parameters, self.covariance
        if cov is None:
            return params
        return ParameterSet(params.values, covariance=cov, names=params.names)

    def _names(self) -> tuple[str, ...]:
        if self.table_parameters is not None:
            return tuple(self.table_parameters.names)
        return tuple(p["parameter"] for p in self._rows())

    def _rows(self) -> list[dict]:
        """The report's parameter rows that name a parameter with a numeric value and sigma (or none)."""
        rows = self.report.get("parameters")

        def number(x) -> bool:
            return isinstance(x, (int, float)) and not isinstance(x, bool)
        return [p for p in rows if isinstance(p, dict) and isinstance(p.get("parameter"), str) and number(p.get("value"))
                and (p.get("sigma") is None or number(p["sigma"]))] if isinstance(rows, list) else []

    @functools.cached_property
    def provenance(self) -> Provenance:
        """Where the table comes from (:class:`Provenance`): the report's, or what the table file tells.

        Raises
        ------
        InputError
            Naming the report when it is not a ``casadi-sins-report/1``, its ``created`` is not an ISO date
            of a calibration, or its conditions' date is beyond the years of one.
        """
        if not self.from_report:
            return Provenance(self.table, self.file_sha256, self.file_date)
        data, path = self.report, self.report_path
        if not str(data.get("format", "")).startswith("casadi-sins-report/"):
            raise InputError(path, f"not a casadi-sins calibration report (format {REPORT_FORMAT})")
        date = _created(data, path)
        conditions = self.conditions
        recorded = conditions.get("date")
        try:
            check_year(parse_date(recorded)) if recorded is not None else None
        except ValueError as exc:
            if "years" in str(exc):
                raise InputError(path, f"conditions.date: {exc}") from None
        rec = _mapping(data, "recording")
        return Provenance(self.table, self.file_sha256, date, self.unit_id, _text(rec.get("name")),
                          _text(rec.get("sha256")), _text(data.get("solver")), _text(data.get("software")),
                          {str(k): str(v) for k, v in _mapping(data, "versions").items()}, from_report=True,
                          conditions=conditions)

    # -- writing --------------------------------------------------------------------------------------------------

    def with_table(self, table: str | Path, table_sha256: str | None) -> "CalibrationRecord":
        """The record as written to ``table`` (its name and the SHA-256 of its text in the report)."""
        report = {**self.report, "table": Path(table).name, TABLE_SHA256_KEY: table_sha256}
        return dataclasses.replace(self, table=Path(table), report=report, file_sha256=table_sha256)

    def judged(self, verdict: str | None, acceptance: dict | None, note: str | None = None) -> "CalibrationRecord":
        """The record judged again (``verdict`` None: against no sheet), ``note`` saying how and when; its
        certificate is dropped (the verdict it showed is gone)."""
        report = {k: v for k, v in self.report.items() if k not in ("verdict", "acceptance", "certificate")}
        if verdict is not None:
            report.update(verdict=verdict, acceptance=dict(acceptance or {}))
        if note:
            report["judged"] = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                                "note": note}
        return dataclasses.replace(self, report=report)

    def report_json(self) -> bytes:
        """The companion report's JSON file."""
        return report_bytes(self.report)
