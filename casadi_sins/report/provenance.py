"""Where a parameter table or a thermal model comes from, as the metadata block of an export.

A parameter table's provenance is its record's (:class:`data.record.CalibrationRecord`, read from the table
and its companion ``NAME.report.json``): the unit id, the date of the calibration, the SHA-256 of the
recording, the solver and the versions of the software.  A table without a companion report keeps what
can be known: its own hash and the file's modification date, flagged as such.  A thermal model's comes
from its companion ``thermal.json`` (:func:`thermal_provenance`).
"""

from __future__ import annotations

from pathlib import Path

from ..core.inputs import check_input_file
from ..core.text import one_line
from ..core.files import file_sha256
from ..data.record import MAX_REPORT_BYTES, Provenance, conditions_metadata, read_provenance  # noqa: F401 (exported)
from ..data.thermal import companion_path as thermal_companion, read_companion


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
    data = read_companion(csv_path)
    if data is None:
        out["provenance"] = "no companion thermal.json: covariance, dates and calibrations unknown"
        return out
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
