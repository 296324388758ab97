"""One unit followed across its calibrations: repeatability, drift, pass/fail against a tolerance sheet.

The tables are ordered by the date of their recording (``[conditions] date`` of the recording, carried
in each table's companion report, its record, :mod:`data.record`); without one, by the date of the
calibration (the report's), and a table without a report falls back to its file date, with a note.  For every
parameter and every pair of consecutive calibrations::

    change = value_2 - value_1              (scale factors: value_2 / value_1 - 1, ppm)
    z      = change / sqrt(sigma_1^2 + sigma_2^2)

in natural units: a change with ``|z|`` above the limit (4 unless the tolerance sheet says
otherwise) is beyond what the two calibrations' noise explains, and is flagged.  The drift rate
per year is the sigma-weighted straight line through all the calibrations (relative to the first),
only where the dates span at least :data:`MIN_DRIFT_SPAN_DAYS` (closer calibrations show repeatability,
and a straight line through them extrapolated to a year is noise times hundreds): else n/a, with a note.
With a tolerance sheet (:mod:`data.tolerance`) each parameter passes or fails: every change within
its ``change`` limit and the drift within its ``drift_per_year`` limit.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.errors import InputError
from ..data.record import Provenance, read_record
from ..data.tolerance import ToleranceSheet
from ..model.parameters import ParameterSet, natural_errors
from ..model.registry import GROUPS, natural_unit_of
from ..report.plots import legend_outside, figure_bytes, pyplot
from ..report.rounding import rounded
from ..report.tables import frame_files

YEAR_S = 365.25 * 86400.0
#: The shortest span of dates over which a drift per year is computed (shorter: n/a, with a note).
MIN_DRIFT_SPAN_DAYS = 1.0


@dataclasses.dataclass
class Calibration:
    """One calibration of the unit: its table and where it comes from."""

    provenance: Provenance
    params: ParameterSet

    @property
    def date(self):
        """When the recording was made (its conditions' date), else when it was calibrated."""
        return self.provenance.recorded or self.provenance.date

    @property
    def date_from(self) -> str:
        """Where :attr:`date` comes from."""
        if self.provenance.recorded is not None:
            return "recording"
        return "calibration report" if self.provenance.from_report else "file date"

    @property
    def label(self) -> str:
        """The date, for tables and plots."""
        return self.date.strftime("%Y-%m-%d %H:%M")


def load_history(paths) -> tuple[list[Calibration], list[str]]:
    """Read the tables and their provenance, ordered by date; notes on what could not be checked.

    Raises
    ------
    InputError
        For fewer than two tables, an unreadable one, or tables of different units.
    """
    if len(paths) < 2:
        raise InputError(None, "history needs at least two parameter tables of one unit")
    records = [read_record(p) for p in paths]
    cals = [Calibration(r.provenance, r.table_parameters) for r in records]
    notes = [f"{c.provenance.table}: no companion report; its file date {c.label} is taken as the date of the "
             "calibration and its unit and recording are not known" for c in cals if not c.provenance.from_report]
    units = {c.provenance.unit_id for c in cals if c.provenance.unit_id}
    if len(units) > 1:
        first = next(c for c in cals if c.provenance.unit_id)
        other = next(c for c in cals if c.provenance.unit_id and c.provenance.unit_id != first.provenance.unit_id)
        raise InputError(other.provenance.table, f"unit {other.provenance.unit_id}, but {first.provenance.table} is "
                         f"unit {first.provenance.unit_id}: history follows one unit")
    if not units:
        notes.append("no table names its unit: they are taken to be of one unit")
    seen: dict[str, Path] = {}
    for c in cals:
        digest = c.provenance.recording_sha256
        if digest and digest in seen:
            notes.append(f"{c.provenance.table} and {seen[digest]} come from the same recording: their changes "
                         "are not independent calibrations")
        elif digest:
            seen[digest] = c.provenance.table
    cals.sort(key=lambda c: c.date)
    undated = [c for c in cals if c.date_from != "recording"]
    if undated and len(undated) < len(cals):
        notes.append(f"{len(undated)} of {len(cals)} recordings carry no [conditions] date: those are dated by "
                     "their calibration")
    elif undated:
        notes.append("no recording carries a [conditions] date: the calibrations are dated by when they were run")
    if drift_span_days(cals) < MIN_DRIFT_SPAN_DAYS:
        notes.append(f"the dates span {drift_span_days(cals) * 86400.0:.3g} s, under {MIN_DRIFT_SPAN_DAYS:g} day: "
                     "no drift per year is given (n/a); the changes show repeatability")
    return cals, notes


def drift_span_days(cals: list[Calibration]) -> float:
    """The span of the calibrations' dates, days."""
    return (max(c.date for c in cals) - min(c.date for c in cals)).total_seconds() / 86400.0


def common_names(cals: list[Calibration]) -> tuple[str, ...]:
    """The parameters every table has, in table order."""
    names = cals[0].params.names
    return tuple(n for n in names if all(n in c.params.names for c in cals))


def _subset(params: ParameterSet, names) -> ParameterSet:
    index = [params.names.index(n) for n in names]
    sigma = None if params.sigma is None else params.sigma[index]
    return ParameterSet(params.values[index], sigma=sigma, names=names)


def changes_frame(cals: list[Calibration], sheet: ToleranceSheet | None = None) -> pd.DataFrame:
    """One row per parameter and pair of consecutive calibrations: change, combined sigma, z (natural units)."""
    names = common_names(cals)
    rows = []
    for before, after in zip(cals[:-1], cals[1:]):
        a, b = _subset(before.params, names), _subset(after.params, names)
        change = natural_errors(b, a)
        combined = np.hypot(a.natural_sigma(), b.natural_sigma())
        years = (after.date - before.date).total_seconds() / YEAR_S
        for i, name in enumerate(names):
            limit = sheet.limit("change", name) if sheet else math.nan
            rows.append({"parameter": name, "unit": natural_unit_of(name), "from": before.label, "to": after.label,
                         "years": years, "change": change[i], "combined_sigma": combined[i],
                         "z": change[i] / combined[i] if combined[i] > 0 else math.nan, "change_limit": limit,
                         "within_limit": "" if math.isnan(limit) else bool(abs(change[i]) <= limit)})
    return pd.DataFrame(rows)


def drift_rates(cals: list[Calibration]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per parameter: sigma-weighted drift rate per year (natural units), its sigma, and the offsets of
    every calibration from the first (natural units; rows: calibrations)."""
    names = common_names(cals)
    first = _subset(cals[0].params, names)
    offsets = np.array([natural_errors(_subset(c.params, names), first) for c in cals])
    sigma = np.array([_subset(c.params, names).natural_sigma() for c in cals])
    years = np.array([(c.date - cals[0].date).total_seconds() / YEAR_S for c in cals])
    rate, rate_sigma = np.full(len(names), np.nan), np.full(len(names), np.nan)
    if np.ptp(years) <= 0 or drift_span_days(cals) < MIN_DRIFT_SPAN_DAYS:
        return rate, rate_sigma, offsets
    for j in range(len(names)):
        w = 1.0 / sigma[:, j] ** 2 if np.all(sigma[:, j] > 0) else np.ones(len(cals))
        t_mean = np.sum(w * years) / np.sum(w)
        sxx = np.sum(w * (years - t_mean) ** 2)
        rate[j] = np.sum(w * (years - t_mean) * offsets[:, j]) / sxx
        rate_sigma[j] = 1.0 / math.sqrt(sxx) if np.all(sigma[:, j] > 0) else math.nan
    return rate, rate_sigma, offsets


def summary_frame(cals: list[Calibration], changes: pd.DataFrame, sheet: ToleranceSheet | None = None) -> pd.DataFrame:
    """One row per parameter: first-to-last change and z, the largest consecutive |z|, the drift rate,
    the limits, whether it is flagged (|z| beyond the limit) and its pass/fail."""
    names = common_names(cals)
    z_limit = sheet.z_limit if sheet else 4.0
    rate, rate_sigma, offsets = drift_rates(cals)
    first, last = _subset(cals[0].params, names), _subset(cals[-1].params, names)
    combined = np.hypot(first.natural_sigma(), last.natural_sigma())
    rows = []
    for j, name in enumerate(names):
        part = changes[changes["parameter"] == name]
        max_z = float(np.nanmax(np.abs(part["z"]))) if part["z"].notna().any() else math.nan
        change_limit = sheet.limit("change", name) if sheet else math.nan
        drift_limit = sheet.limit("drift_per_year", name) if sheet else math.nan
        failed = (not math.isnan(change_limit) and bool((part["change"].abs() > change_limit).any())) or \
            (not math.isnan(drift_limit) and not math.isnan(rate[j]) and abs(rate[j]) > drift_limit)
        limited = not (math.isnan(change_limit) and math.isnan(drift_limit))
        rows.append({"parameter": name, "unit": natural_unit_of(name), "calibrations": len(cals),
                     "change_first_to_last": offsets[-1, j], "combined_sigma": combined[j],
                     "z_first_to_last": offsets[-1, j] / combined[j] if combined[j] > 0 else math.nan,
                     "max_abs_z": max_z, "drift_per_year": rate[j], "drift_sigma_per_year": rate_sigma[j],
                     "change_limit": change_limit, "drift_limit_per_year": drift_limit,
                     "flagged": bool(max_z > z_limit), "status": ("fail" if failed else "pass") if limited else
                     "no tolerance"})
    return pd.DataFrame(rows)


def calibrations_frame(cals: list[Calibration]) -> pd.DataFrame:
    """The calibrations in date order with their provenance and recording conditions."""
    return pd.DataFrame([{"date": c.date.isoformat(timespec="seconds"), "table": str(c.provenance.table),
                          "unit_id": c.provenance.unit_id or "", "recording": c.provenance.recording or "",
                          "recording_sha256": c.provenance.recording_sha256 or "", "solver": c.provenance.solver or "",
                          "date_from": c.date_from,
                          "calibrated": c.provenance.date.isoformat(timespec="seconds"),
                          **{k: c.provenance.conditions.get(k, "") for k in ("temperature_c", "operator", "bench")}}
                         for c in cals])


def plot_group(cals: list[Calibration], group_key: str) -> bytes:
    """Each parameter of a group against the date: offset from the first calibration with 1-sigma bars."""
    names = common_names(cals)
    group = GROUPS[group_key]
    members = [n for n in group.names if n in names]
    _, _, offsets = drift_rates(cals)
    dates = [c.date for c in cals]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for n in members:
        j = names.index(n)
        sig = [_subset(c.params, names).natural_sigma()[j] for c in cals]
        ax.errorbar(dates, offsets[:, j], yerr=sig, marker="o", capsize=3, label=n)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_ylabel(f"change since the first calibration ({group.natural_unit})")
    ax.set_title(f"{group.label}: {len(cals)} calibrations, 1-sigma bars")
    legend_outside(ax, fontsize=8)
    fig.autofmt_xdate()
    return figure_bytes(fig)


def history_files(cals: list[Calibration], out_dir, sheet: ToleranceSheet | None = None,
                  notes: list[str] | None = None) -> tuple[dict[Path, bytes], pd.DataFrame]:
    """Every file of a history (tables CSV + Markdown, a plot per group), and its summary table."""
    out = Path(out_dir)
    unit = next((c.provenance.unit_id for c in cals if c.provenance.unit_id), "unit")
    changes = changes_frame(cals, sheet)
    summary = summary_frame(cals, changes, sheet)
    title = (f"{unit}: {len(cals)} calibrations {cals[0].label} to {cals[-1].label}; changes in natural units "
             f"(scale factors ppm of the value), z against the combined sigma")
    files = frame_files(calibrations_frame(cals), out / "history-calibrations", f"{unit}: calibrations by date")
    files.update(frame_files(changes, out / "history-changes", title, "%.3g",
                             rounded(changes, {"change": "combined_sigma"}, signed=True)))
    md_notes = "".join(f"; note: {n}" for n in notes or [])
    files.update(frame_files(summary, out / "history-summary", title + md_notes, "%.3g",
                             rounded(summary, {"change_first_to_last": "combined_sigma",
                                               "drift_per_year": "drift_sigma_per_year"}, signed=True)))
    names = common_names(cals)
    for key, group in GROUPS.items():
        if any(n in names for n in group.names):
            files[out / f"history-{key.replace('_', '-')}.png"] = plot_group(cals, key)
    return files, summary
