"""Every file ``calibrate`` writes, assembled together: the parameter table, its companion report (and the
full report and certificate when asked), and the exports carrying the table's provenance.  The command
writes them all at once (:func:`core.files.write_files`) and prints; nothing of the product is built there.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from ..calibrate.result import CalibrationResult
from ..core.version import software_versions
from ..data.conditions import conditions_dict
from ..data.record import parse_report, report_path
from ..data.recording import Recording
from ..data.tables import table_text
from ..model.parameters import ParameterSet
from .acceptance import Verdict
from .calibration import recording_hash, report_files
from .exports import export_files
from .provenance import conditions_metadata


def calibration_files(result: CalibrationResult, rec: Recording, table_path: str | Path,
                      report_dir: str | Path | None = None, truth: ParameterSet | None = None,
                      command: str | None = None, unit_id: str | None = None, verdict: Verdict | None = None,
                      certificate: str | None = None, exports=()) -> tuple[dict[Path, bytes], dict]:
    """The files of a calibration written as ``table_path`` (``{path: content}``) and its report's data.

    The table carries the verdict's acceptance column and the distrust mark; the report (JSON, Markdown;
    in ``report_dir`` the full report; the certificate with ``certificate``) names the table's SHA-256; each
    export in ``exports`` carries the provenance an ``export`` of the written table would read back: unit,
    dates, software, hashes of the table and the recording, solver, versions and recording conditions.
    """
    table = Path(table_path)
    files = {table: table_text(result.parameters, truth, acceptance=verdict and verdict.outcome,
                               distrusted=bool(result.distrust)).encode()}
    table_sha256 = hashlib.sha256(files[table]).hexdigest()
    files.update(report_files(result, rec, table_path, report_dir, truth, command=command, unit_id=unit_id,
                              verdict=verdict, certificate=certificate, table_sha256=table_sha256))
    report = parse_report(files[report_path(table)], report_path(table))  # the date and software, as `export` gives them
    files.update(export_files(result.parameters, table_path, exports, {
        "unit_id": unit_id, "table": str(table_path), "calibrated": report["created"],
        "calibrated_with": report["software"], "table_sha256": table_sha256, "recording": rec.name,
        "recording_sha256": recording_hash(rec), "solver": result.solver,
        "versions": ", ".join(f"{k} {v}" for k, v in software_versions().items()),
        **conditions_metadata(conditions_dict(rec))}))
    return files, report
