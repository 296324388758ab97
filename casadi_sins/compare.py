"""Both solvers on one recording, side by side: values, differences, errors, timing, residuals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from . import parameters as P
from .recording import Recording
from .report import save_figure, write_frame
from .result import CalibrationResult
from .strapdown import navigate, static_velocities


def static_residuals(rec: Recording, result: CalibrationResult) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Velocity in each static segment relative to its first sample, navigated with the result's own model.

    Returns ``{segment number: (time, velocity (n, 3))}``.  The NLP's estimated start attitudes are used
    where it has them; the ILS navigates from its alignment, as it does in its own iteration.
    """
    navs = navigate(rec, result.parameters.values, result.info.get("start_attitudes"))
    return {seg.number: (t, v - v[0]) for seg, t, v in static_velocities(rec, navs)}


def comparison_table(results: dict[str, CalibrationResult], truth: P.ParameterSet | None = None) -> pd.DataFrame:
    """Per parameter: each solver's value and sigma, their difference, and errors against a truth.

    Rows are the union of the solvers' parameters (an extended NLP beside the 21 of the ILS: the ILS's
    extra rows are empty)."""
    names = list(results)
    rows = list(dict.fromkeys(n for res in results.values() for n in res.parameters.names))
    frame = pd.DataFrame({"parameter": rows, "unit": [P.unit_of(n) for n in rows],
                          "natural unit": [P.natural_unit_of(n) for n in rows]})

    def column(res, values):
        lookup = dict(zip(res.parameters.names, values))
        return np.array([lookup.get(n, np.nan) for n in rows])

    for name in names:
        params = results[name].parameters
        frame[f"{name} value"] = column(results[name], params.values)
        frame[f"{name} sigma (natural)"] = column(results[name], params.natural_sigma())
    if len(names) == 2:
        a, b = (results[n].parameters for n in names)
        frame[f"{names[0]} - {names[1]} (natural)"] = P.natural_errors(a.aligned(rows), b.aligned(rows), rows)
    if truth is not None:
        frame["truth"] = truth.aligned(rows)
        for name in names:
            err = column(results[name], P.natural_errors(results[name].parameters, truth))
            frame[f"{name} error (natural)"] = err
            frame[f"{name} error/sigma"] = err / frame[f"{name} sigma (natural)"]
    return frame


def summary_table(rec: Recording, results: dict[str, CalibrationResult],
                  residuals: dict[str, dict]) -> pd.DataFrame:
    rows = []
    for name, res in results.items():
        velocities = np.concatenate([v for _, v in residuals[name].values()])
        rows.append({"solver": name, "iterations": res.iterations, "wall time (s)": res.wall_time,
                     "own residual rms (whitened)": res.residual_rms,
                     "static velocity rms (mm/s)": 1e3 * float(np.sqrt(np.mean(velocities**2))),
                     "sigma means": res.sigma_meaning})
    return pd.DataFrame(rows)


def plot_residuals(rec: Recording, residuals: dict[str, dict], path: str | Path) -> Path:
    """Velocity in each static interval (relative to its start), E/N/U rows, intervals side by side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(14, 8), sharex=True)
    segments = [s for s in rec.static_segments]
    for name, per_segment in residuals.items():
        offset = 0.0
        for k, seg in enumerate(segments):
            t, v = per_segment[seg.number]
            x = offset + (t - t[0])
            for axis in range(3):
                axes[axis].plot(x, v[:, axis] * 1e3, lw=0.7, color=f"C{list(residuals).index(name)}",
                                label=name if k == 0 and axis == 0 else None)
            offset += (t[-1] - t[0]) * 1.08
    offset = 0.0
    for seg in segments:
        t, _ = next(iter(residuals.values()))[seg.number]
        for axis in range(3):
            axes[axis].axvline(offset, color="0.8", lw=0.6)
        axes[0].text(offset + 2, 1.02, seg.orientation, transform=axes[0].get_xaxis_transform(), fontsize=7)
        offset += (t[-1] - t[0]) * 1.08
    for axis, label in enumerate("ENU"):
        axes[axis].set_ylabel(f"v_{label} (mm/s)")
    axes[-1].set_xlabel("time within the static intervals, laid side by side (s)")
    axes[0].legend(fontsize=8, loc="upper right")
    fig.suptitle(f"{rec.name}: velocity in each static interval after calibration (relative to its start)",
                 y=0.995)
    return save_figure(fig, path)


def compare(rec: Recording, out_dir: str | Path, truth: P.ParameterSet | None = None, progress=None
            ) -> tuple[dict[str, CalibrationResult], pd.DataFrame, pd.DataFrame]:
    """Run both solvers and write the comparison (CSV, Markdown, PNG) and each parameter table."""
    from .solvers import calibrate

    out_dir = Path(out_dir)
    results = {name: calibrate(rec, solver=name, progress=progress) for name in ("nlp", "ils")}
    residuals = {name: static_residuals(rec, res) for name, res in results.items()}
    table = comparison_table(results, truth)
    summary = summary_table(rec, results, residuals)
    stem = out_dir / f"{rec.file_stem}-compare"
    write_frame(table, stem, f"{rec.name}: NLP and ILS side by side (natural units: ug, ppm, arcsec, deg/h)")
    write_frame(summary, out_dir / f"{rec.file_stem}-compare-summary", f"{rec.name}: solvers")
    plot_residuals(rec, residuals, out_dir / f"{rec.file_stem}-compare-residuals.png")
    for name, res in results.items():
        P.write_table(out_dir / f"{rec.file_stem}-{name}.csv", res.parameters, truth)
    return results, table, summary
