"""Both solvers on one recording, side by side: values, differences, errors, timing, residuals."""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path

import numpy as np
import pandas as pd

from ..calibrate import calibrate
from ..calibrate.result import CalibrationResult
from ..data.recording import Recording
from ..data.tables import table_text
from ..model.parameters import ParameterSet, natural_errors, truth_errors
from ..model.registry import natural_unit_of, natural_value_of, unit_of
from ..report.plots import plot_residuals, static_residuals
from ..report.rounding import display, sigma_in_value_unit
from ..report.tables import frame_files


def comparison_table(results: dict[str, CalibrationResult], truth: ParameterSet | None = None) -> pd.DataFrame:
    """Per parameter: each solver's value and sigma, their difference, and errors against a truth.

    Rows are the union of the solvers' parameters (an extended NLP beside the 21 of the ILS: the ILS's
    extra rows are empty)."""
    names = list(results)
    rows = list(dict.fromkeys(n for res in results.values() for n in res.parameters.names))
    frame = pd.DataFrame({"parameter": rows, "unit": [unit_of(n) for n in rows],
                          "natural unit": [natural_unit_of(n) for n in rows]})

    def column(res, values):
        lookup = dict(zip(res.parameters.names, values))
        return np.array([lookup.get(n, np.nan) for n in rows])

    for name in names:
        params = results[name].parameters
        frame[f"{name} value"] = column(results[name], params.values)
        frame[f"{name} sigma (natural)"] = column(results[name], params.natural_sigma())
    if len(names) == 2:
        a, b = (results[n].parameters for n in names)
        frame[f"{names[0]} - {names[1]} (natural)"] = natural_errors(a.aligned(rows), b.aligned(rows), rows)
    if truth is not None:
        frame["truth"] = truth.aligned(rows)
        for name in names:
            err = column(results[name], truth_errors(results[name].parameters, truth))
            frame[f"{name} error (natural)"] = err
            frame[f"{name} error/sigma"] = err / frame[f"{name} sigma (natural)"]
    return frame


def summary_table(rec: Recording, results: dict[str, CalibrationResult],
                  residuals: dict[str, dict]) -> pd.DataFrame:
    """Per solver: iterations, wall time, whitened and static-velocity residuals, what sigma means."""
    rows = []
    for name, res in results.items():
        velocities = np.concatenate([v for _, v in residuals[name].values()])
        rows.append({"solver": name, "iterations": res.nit, "wall time (s)": res.wall_time,
                     "own residual rms (whitened)": res.residual_rms,
                     "static velocity rms (mm/s)": 1e3 * float(np.sqrt(np.mean(velocities**2))),
                     "sigma means": res.sigma_meaning})
    return pd.DataFrame(rows)


def comparison_display(table: pd.DataFrame) -> pd.DataFrame:
    """The comparison as people read it: each solver's value in the report's value units (ug, deg/h, arcsec;
    pulse weights) rounded to its sigma, sigmas to two digits, each error rounded to its solver's sigma and the
    difference to the smaller sigma, error/sigma to two decimals; natural units labelled."""
    solvers = [c[: -len(" value")] for c in table.columns if c.endswith(" value")]
    frame = table[["parameter"]].copy()
    frame["value unit"] = [natural_value_of(n, 1.0)[1] for n in table["parameter"]]
    frame["natural unit"] = table["natural unit"]
    pairs, sigmas, ratios = {}, [], []
    for name in solvers:
        natural = [natural_value_of(n, v)[0] for n, v in zip(table["parameter"], table[f"{name} value"])]
        frame[f"{name} value"] = natural
        frame[f"_{name} sigma"] = [sigma_in_value_unit(n, v, s) for n, v, s in
                                   zip(table["parameter"], natural, table[f"{name} sigma (natural)"])]
        frame[f"{name} sigma (natural)"] = table[f"{name} sigma (natural)"]
        pairs[f"{name} value"] = f"_{name} sigma"
        sigmas.append(f"{name} sigma (natural)")
    smallest = table[[f"{n} sigma (natural)" for n in solvers]].min(axis=1)
    frame["_smallest"] = smallest
    for col in table.columns:
        if col.endswith("(natural)") and ("error" in col or " - " in col):
            frame[col] = table[col]
            own = col.replace(" error (natural)", " sigma (natural)")
            pairs[col] = own if own in frame and own != col else "_smallest"
        elif col.endswith("error/sigma"):
            frame[col] = table[col]
            ratios.append(col)
    shown = display(frame, pairs, sigmas, ratios)
    return shown[[c for c in shown.columns if not c.startswith("_")]]


def summary_display(summary: pd.DataFrame) -> pd.DataFrame:
    """The solvers' summary as people read it: timings to 0.01 s, residuals to two significant digits."""
    out = display(summary, sigmas=["own residual rms (whitened)", "static velocity rms (mm/s)"])
    out["wall time (s)"] = [f"{x:.2f}" for x in summary["wall time (s)"]]
    return out


@dataclasses.dataclass
class Comparison:
    """Both solvers on one recording: their results, the static residuals, the side-by-side tables."""

    results: dict[str, CalibrationResult]
    residuals: dict[str, dict]
    table: pd.DataFrame
    summary: pd.DataFrame


def compare(rec: Recording, truth: ParameterSet | None = None, progress=None) -> Comparison:
    """Run both solvers on a recording and put them side by side."""
    results = {name: calibrate(rec, solver=name, progress=progress) for name in ("nlp", "ils")}
    residuals = {name: static_residuals(rec, res) for name, res in results.items()}
    return Comparison(results, residuals, comparison_table(results, truth), summary_table(rec, results, residuals))


def comparison_files(rec: Recording, comparison: Comparison, out_dir: str | Path,
                     truth: ParameterSet | None = None) -> dict[Path, bytes]:
    """Every file of a comparison (tables, residual plot, each solver's parameter table) as ``{path: bytes}``,
    to be written together."""
    out_dir = Path(out_dir)
    stem = out_dir / f"{rec.file_stem}-compare"
    files = frame_files(comparison.table, stem,
                        f"{rec.name}: NLP and ILS side by side (natural units: ug, ppm, arcsec, deg/h; values rounded "
                        "to their sigma, full precision in the CSV)", display=comparison_display(comparison.table))
    files.update(frame_files(comparison.summary, out_dir / f"{rec.file_stem}-compare-summary", f"{rec.name}: solvers",
                             display=summary_display(comparison.summary)))
    plot = io.BytesIO()
    plot_residuals(rec, comparison.residuals, plot)
    files[out_dir / f"{rec.file_stem}-compare-residuals.png"] = plot.getvalue()
    for name, res in comparison.results.items():
        files[out_dir / f"{rec.file_stem}-{name}.csv"] = table_text(res.parameters, truth).encode()
    return files
