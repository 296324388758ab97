"""The conditions a recording was made in: the optional ``[conditions]`` table of its description.

::

    [conditions]
    temperature_c = 23.5             # degC, of the unit during the recording
    date = "2024-05-17T09:30:00Z"    # ISO 8601 (a date, or a date and time)
    operator = "A. Engineer"
    bench = "rate table 2"
    unit_id = "SN-0042"

Every key is optional.  The CSV may carry a ``temperature`` column (degC, per sample); without
``temperature_c`` its mean over the static segments is the recording's temperature
(:func:`recording_temperature_c`).  The date orders and dates a unit's history by when it was
recorded, not when it was calibrated.
"""

from __future__ import annotations

import dataclasses
import datetime
import math

import numpy as np

from ..core.errors import InputError, shown

__all__ = ["Conditions", "parse_conditions", "recording_temperature_c", "conditions_dict", "parse_date",
           "TEMPERATURE_RANGE_C", "KEYS"]

#: A unit on a bench or in a thermal chamber: anything beyond is a typo (Kelvin, Fahrenheit).
TEMPERATURE_RANGE_C = (-80.0, 150.0)
#: Longest text of operator, bench, unit id (one line).
MAX_TEXT = 200
KEYS = ("temperature_c", "date", "operator", "bench", "unit_id")


@dataclasses.dataclass(frozen=True)
class Conditions:
    """The recording conditions; every field optional (``None`` when not given).

    Attributes
    ----------
    temperature_c : float or None
        Temperature of the unit, degC.
    date : str or None
        ISO 8601, normalised: ``YYYY-MM-DD`` or ``YYYY-MM-DDTHH:MM:SS[+HH:MM]``.
    operator, bench, unit_id : str or None
        One line each.
    """

    temperature_c: float | None = None
    date: str | None = None
    operator: str | None = None
    bench: str | None = None
    unit_id: str | None = None

    def to_dict(self) -> dict:
        """Only the fields that are set."""
        return {k: v for k, v in dataclasses.asdict(self).items() if v is not None}

    def datetime(self) -> datetime.datetime | None:
        """The date as an aware datetime (UTC when no zone is given; midnight for a date), or None."""
        return None if self.date is None else parse_date(self.date)

    def __bool__(self) -> bool:
        return bool(self.to_dict())


def _moment(value) -> tuple[datetime.datetime, bool]:
    """``(datetime as given (naive without a zone), whether it is a date alone)``; ValueError if not ISO 8601."""
    if isinstance(value, datetime.datetime):
        return value, False
    if isinstance(value, datetime.date):
        return datetime.datetime(value.year, value.month, value.day), True
    if isinstance(value, str):
        text = value.strip()
        if text[-1:] in ("Z", "z"):
            text = text[:-1] + "+00:00"
        try:
            return datetime.datetime.fromisoformat(text), len(text) == 10
        except ValueError:
            pass
    raise ValueError(f"{shown(value)} is not an ISO 8601 date (YYYY-MM-DD or YYYY-MM-DDTHH:MM:SS)")


def parse_date(value) -> datetime.datetime:
    """An ISO 8601 date or date-time (text, or a TOML date / date-time) as an aware datetime (UTC when
    no zone is given, midnight for a date alone).

    Raises
    ------
    ValueError
        When it is not one.
    """
    moment = _moment(value)[0]
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=datetime.timezone.utc)


#: The years of a recording or a calibration (``[first, last)``): a date outside is a typing error (and
#: 9999-12-31 overflows date arithmetic and every plot's date axis).
DATE_YEARS = (1970, 2200)


def check_year(moment: datetime.datetime) -> None:
    """Refuse (ValueError) a date outside :data:`DATE_YEARS`."""
    first, last = DATE_YEARS
    if not first <= moment.year < last:
        raise ValueError(f"{moment.date().isoformat()} is not a date of a recording (years {first} to {last - 1})")


def _normalised_date(value) -> str:
    """The text form of a date: ``YYYY-MM-DD`` for a date alone, else to the second with the zone if given."""
    moment, date_only = _moment(value)
    check_year(moment)
    return moment.date().isoformat() if date_only else moment.isoformat(timespec="seconds")


def parse_conditions(table, path) -> tuple[Conditions, list[str]]:
    """The ``[conditions]`` table of a description (``None`` when absent).

    Returns
    -------
    Conditions, list of str
        The conditions and warnings (keys that are not conditions, ignored).

    Raises
    ------
    InputError
        One line naming the file and the key at fault.
    """
    if table is None:
        return Conditions(), []
    if not isinstance(table, dict):
        raise InputError(path, f"'conditions' must be a table ([conditions]), found {shown(table)}")
    values = {}
    temperature = table.get("temperature_c")
    if temperature is not None:
        if isinstance(temperature, bool) or not isinstance(temperature, (int, float)) or not math.isfinite(temperature):
            raise InputError(path, f"[conditions] temperature_c must be a finite number of degC, found {shown(temperature)}")
        low, high = TEMPERATURE_RANGE_C
        if not low <= temperature <= high:
            raise InputError(path, f"[conditions] temperature_c {temperature:g} is outside {low:g}..{high:g} degC "
                             "(Kelvin or Fahrenheit?)")
        values["temperature_c"] = float(temperature)
    if table.get("date") is not None:
        try:
            values["date"] = _normalised_date(table["date"])
        except ValueError as exc:
            raise InputError(path, f"[conditions] date {exc}") from None
    for key in ("operator", "bench", "unit_id"):
        text = table.get(key)
        if text is None:
            continue
        if isinstance(text, (int, float)) and not isinstance(text, bool):
            text = str(text)  # a bench or unit numbered without quotes
        if not isinstance(text, str) or not text.strip() or len(text) > MAX_TEXT or not text.isprintable():
            raise InputError(path, f"[conditions] {key} must be one line of 1 to {MAX_TEXT} printable characters, "
                             f"found {shown(text)}")
        values[key] = text.strip()
    unknown = sorted(set(table) - set(KEYS))
    warnings = ([f"{path}: [conditions] key(s) {', '.join(unknown)} ignored (known: {', '.join(KEYS)})"]
                if unknown else [])
    return Conditions(**values), warnings


def recording_temperature_c(rec) -> float | None:
    """The recording's temperature, degC: ``[conditions] temperature_c``, else the mean of the CSV's
    ``temperature`` column over the static segments (over all samples when there are none), else None."""
    if rec.conditions.temperature_c is not None:
        return rec.conditions.temperature_c
    column = getattr(rec, "temperature", None)
    if column is None or len(column) == 0:
        return None
    parts = [column[rec.segment_samples(seg)] for seg in rec.static_segments]
    parts = [p for p in parts if len(p)]
    return float(np.mean(np.concatenate(parts)) if parts else np.mean(column))


def conditions_dict(rec) -> dict:
    """The conditions of a recording for a report: the set fields, ``temperature_c`` from the column when
    the description gives none (then ``temperature_source`` says so)."""
    out = rec.conditions.to_dict()
    if "temperature_c" not in out:
        temperature = recording_temperature_c(rec)
        if temperature is not None:
            out["temperature_c"] = temperature
            out["temperature_source"] = "mean of the CSV temperature column over the static segments"
    return out
