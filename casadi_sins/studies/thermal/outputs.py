"""The files of a thermal fit: ``thermal.csv`` (+ ``thermal.json``), ``thermal.md``, plots, tables at temperatures.

Every file is returned as ``{path: bytes}`` and written together by :func:`core.files.write_files`.
``at-<T>C.csv`` is a parameter table (``parameter,unit,value,sigma``) that every command reads; its
companion ``at-<T>C.report.json`` carries the full covariance (``G Sigma G^T``, :mod:`model.thermal`)
and the temperature in the keys the calibration report uses (``covariance``, ``conditions``).
"""

from __future__ import annotations

import datetime
import hashlib
from pathlib import Path

import numpy as np
import pandas as pd

from ...core.version import build_identity, software_versions
from ...data.record import CalibrationRecord, report_path
from ...data.tables import table_text
from ...data.thermal import write_thermal
from ...model.registry import GROUPS, natural_size, natural_unit_of, relative_mask
from ...model.thermal import ThermalModel
from ...report.plots import figure_bytes, pyplot
from ...report.rounding import format_sigma, format_with_sigma
from ...report.tables import markdown_table
from .fit import ThermalFit


def at_name(temperature_c: float) -> str:
    """``at-<T>C.csv`` for a temperature (``at-10C.csv``, ``at--10C.csv``, ``at-12.5C.csv``)."""
    return f"at-{float(temperature_c):g}C.csv"


def natural_coefficients(model: ThermalModel) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients and sigma (n, 3) in natural units: ``p_ref`` as its natural-unit size (scale factors
    in ppm of themselves: 0), ``a1`` per degC, ``a2`` per degC^2 (scale factors ppm of ``p_ref``)."""
    size = natural_size(model.names, model.coefficients[:, 0])
    coef = model.coefficients / size[:, None]
    coef[relative_mask(model.names), 0] = 0.0
    return coef, model.sigma / size[:, None]


def summary_frame(fit: ThermalFit) -> pd.DataFrame:
    """One row per parameter, natural units: p_ref (not for scale factors), a1, a2, order, chi^2/dof, widening."""
    coef, sig = natural_coefficients(fit.model)
    names = fit.model.names
    rel = relative_mask(names)
    rows = []
    for i, name in enumerate(names):
        unit = natural_unit_of(name)
        rows.append({"parameter": name, "unit": unit,
                     "p_ref": "(see thermal.csv)" if rel[i] else format_with_sigma(coef[i, 0], sig[i, 0]),
                     "p_ref_sigma": format_sigma(sig[i, 0]),
                     "a1 (unit/degC)": format_with_sigma(coef[i, 1], sig[i, 1], signed=True),
                     "a1_sigma": format_sigma(sig[i, 1]),
                     "a2 (unit/degC^2)": format_with_sigma(coef[i, 2], sig[i, 2], signed=True),
                     "a2_sigma": format_sigma(sig[i, 2]), "order": int(fit.model.orders[i]),
                     "a2/sigma (quadratic fit)": fit.a2_z[i],
                     "chi2/dof": fit.chi2[i] / fit.dof[i] if fit.dof[i] > 0 else np.nan,
                     "sigma widened by": fit.widened[i]})
    return pd.DataFrame(rows)


def thermal_markdown(fit: ThermalFit, ats: list[float], notes: list[str]) -> str:
    """The human-readable summary: the model, per-parameter coefficients, warnings, the calibrations."""
    m = fit.model
    low, high = m.range_c
    lines = ["# Thermal model", "",
             f"p(T) = p_ref + a1 (T - {m.reference_c:g}) + a2 (T - {m.reference_c:g})^2 per parameter, fitted by "
             f"generalised least squares to {len(fit.points)} calibrations from {low:g} to {high:g} degC with their full "
             "covariances. Natural units (scale factors: ppm of p_ref); full precision SI in thermal.csv, the joint "
             "covariance of the coefficients in thermal.json. Sigma are 1-sigma; an a2 of 0 with a sigma is a "
             "curvature the data do not show but cannot exclude (kept in every sigma).", "",
             "| table | temperature (degC) |", "| --- | --- |"]
    lines += [f"| {p.label} | {p.temperature_c:g} |" for p in fit.points]
    lines += ["", markdown_table(summary_frame(fit), "%.3g"), ""]
    if fit.warnings or notes:
        lines += ["## Warnings and notes", ""] + [f"- {w}" for w in fit.warnings + notes] + [""]
    if ats:
        lines += ["## Tables at other temperatures", ""]
        lines += [f"- {at_name(t)}: {t:g} degC" + (" (extrapolated beyond the calibrated range)"
                                                   if m.extrapolates(t) else "") for t in ats]
    return "\n".join(lines) + "\n"


def at_record(model: ThermalModel, temperature_c: float, unit_id: str | None) -> CalibrationRecord:
    """The record of the table at a temperature (:class:`data.record.CalibrationRecord`): its covariance and the
    temperature as its conditions, in the keys of a calibration report."""
    message = (f"evaluated from the thermal model at {temperature_c:g} degC (reference {model.reference_c:g} degC, "
               f"calibrated {model.range_c[0]:g} .. {model.range_c[1]:g} degC)")
    return CalibrationRecord.of_calibration(model.at(temperature_c), solver="thermal", unit_id=unit_id,
                                            conditions={"temperature_c": float(temperature_c)},
                                            details={"message": message,
                                                     "extrapolated": model.extrapolates(temperature_c)})


def plot_group(fit: ThermalFit, key: str) -> bytes | None:
    """Each parameter of a group against temperature (natural units, relative to ``p_ref``): above, the
    calibrations with error bars and the fitted curve; below, each calibration's residual from the curve with its
    error bar and the curve's 1-sigma band (where a bad run or hysteresis shows)."""
    names = [n for n in GROUPS[key].names if n in fit.model.names]
    if not names:
        return None
    plt = pyplot()
    fig, axes = plt.subplots(2, len(names), figsize=(3.6 * len(names), 5.4), squeeze=False, sharex=True)
    m = fit.model
    grid = np.linspace(min(m.range_c[0], m.reference_c) - 5, max(m.range_c[1], m.reference_c) + 5, 80)
    size = natural_size(m.names, m.coefficients[:, 0])
    temps = np.array([p.temperature_c for p in fit.points])
    for column, name in enumerate(names):
        i = m.names.index(name)
        top, bottom = axes[0][column], axes[1][column]
        curve = (m.values_at(grid)[:, i] - m.coefficients[i, 0]) / size[i]
        band = np.array([np.sqrt(m.at(t).covariance[i, i]) for t in grid]) / size[i] if m.covariance is not None \
            else np.zeros_like(grid)
        vals = np.array([p.params.values[i] for p in fit.points])
        errs = np.array([p.params.sigma[i] for p in fit.points]) / size[i]
        top.plot(grid, curve, color="C0", label=f"fit (order {m.orders[i]})")
        top.errorbar(temps, (vals - m.coefficients[i, 0]) / size[i], yerr=errs, fmt="o", color="C3", capsize=3,
                     label="calibrations")
        top.set_title(name, fontsize=9)
        top.set_ylabel(f"p - p_ref ({natural_unit_of(name)})")
        bottom.fill_between(grid, -band, band, color="C0", alpha=0.2, label="fit 1-sigma")
        bottom.axhline(0.0, color="C0", lw=0.8)
        bottom.errorbar(temps, (vals - m.values_at(temps)[:, i]) / size[i], yerr=errs, fmt="o", color="C3", capsize=3)
        bottom.set_xlabel("temperature (degC)")
        bottom.set_ylabel(f"residual ({natural_unit_of(name)})")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    axes[1][0].legend(fontsize=7)
    fig.tight_layout()
    return figure_bytes(fig)


def thermal_files(fit: ThermalFit, out: str | Path, ats: list[float], notes: list[str], unit_id: str | None = None,
                  plots: bool = True) -> dict[Path, bytes]:
    """``{path: bytes}`` of every output of a thermal fit in the folder ``out``."""
    out = Path(out)
    extra = {"software": build_identity(), "versions": software_versions(),
             "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"), "unit_id": unit_id,
             "calibrations": [{"table": p.label, "temperature_c": p.temperature_c, **(p.origin or {})}
                              for p in fit.points],
             "chi2": fit.chi2.tolist(), "dof": fit.dof.tolist(), "sigma_widened_by": fit.widened.tolist(),
             "a2_over_sigma_quadratic_fit": [None if not np.isfinite(z) else float(z) for z in fit.a2_z],
             "warnings": list(fit.warnings), "notes": list(notes)}
    files = write_thermal(out / "thermal.csv", fit.model, extra)
    files[out / "thermal.md"] = thermal_markdown(fit, ats, notes).encode()
    for t in ats:
        table = out / at_name(t)
        files[table] = table_text(fit.model.at(t)).encode()
        record = at_record(fit.model, t, unit_id).with_table(table, hashlib.sha256(files[table]).hexdigest())
        files[report_path(table)] = record.report_json()
    if plots:
        for key in GROUPS:
            png = plot_group(fit, key)
            if png is not None:
                files[out / f"thermal-{key}.png"] = png
    return files
