"""The export formats of a parameter table and the file each writes, light enough for ``casadi-sins --help``
(the writers are in :mod:`report.exports`, which takes its formats from here)."""

from __future__ import annotations

#: Export format -> (suffix of the file beside the table ``NAME.csv``, what the file holds).
EXPORT_FORMATS = {
    "json": ("compensation.json", "compensation matrices"),
    "yaml": ("compensation.yaml", "compensation matrices"),
    "psins": ("clbt.m", "the PSINS clbt struct"),
    "c": ("compensation.h", "a C header for firmware: float64 arrays, inline function"),
}


def export_formats_help() -> str:
    """What each export format writes, for a help text: ``json: compensation matrices (NAME.compensation.json);
    ...``."""
    return "; ".join(f"{fmt}: {what} (NAME.{suffix})" for fmt, (suffix, what) in EXPORT_FORMATS.items())
