"""The paper's navigation check (section 2.3): free-inertial navigation of a fresh static recording.

A fresh static recording is simulated (the problem's sensors, truth and noise, one level position),
each parameter table is applied, the unit is aligned on the first minutes (eq. 14) and then navigates
free-inertially (:mod:`nav.free_inertial`).  The horizontal position error after 1 h is what the paper
reports (< 1 nmile for its real product).
"""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path

import numpy as np
import pandas as pd

from ..calibrate.initial import rough_parameters
from ..core.errors import InputError
from ..data.problem import GroupPlan, Problem, Timing
from ..nav.free_inertial import NAUTICAL_MILE, NavigationRun, navigate_free
from ..report.plots import legend_outside, pyplot, save_figure
from ..report.rounding import display, float_columns
from ..core.files import safe_stem, write_files
from ..report.tables import frame_files
from ..sim import simulate

#: The longest navigation check, in samples of alignment and navigation (27 h at 100 Hz): a simulated static
#: recording that long already takes a few GB.
MAX_SAMPLES = 1e7


def check_durations(align_s: float, duration_s: float | None, rate_hz: float) -> None:
    """Refuse an alignment or a navigation time that is not a positive number of seconds, or longer in all than
    :data:`MAX_SAMPLES` (naming ``--align-s`` and ``--duration-s``)."""
    if not align_s > 0 or (duration_s is not None and not duration_s > 0):
        raise InputError(None, f"--align-s and --duration-s must be positive numbers of seconds, found {align_s:g}"
                         + ("" if duration_s is None else f" and {duration_s:g}"))
    if (align_s + (duration_s or 0.0)) * rate_hz > MAX_SAMPLES:
        raise InputError(None, f"--align-s {align_s:g} and --duration-s {duration_s or 0.0:g} at {rate_hz:g} Hz are "
                         f"more than {MAX_SAMPLES:.3g} samples: at most {MAX_SAMPLES / rate_hz:.0f} s in all")


def navigation_problem(problem: Problem, duration_s: float = 3600.0, align_s: float = 300.0,
                       orientation: str = "ENU") -> Problem:
    """One static position: ``align_s`` of alignment, then ``duration_s`` of navigation."""
    timing = Timing(static_s=align_s + duration_s, rotation_s=1.0, rate_profile=problem.timing.rate_profile)
    return dataclasses.replace(problem, name=f"{problem.name}-navcheck", groups=(GroupPlan(orientation, ()),),
                               timing=timing)


def navigation_check(problem: Problem, tables: dict[str, np.ndarray], seed: int = 0, duration_s: float = 3600.0,
                     align_s: float = 300.0) -> tuple[list[NavigationRun], pd.DataFrame]:
    """Navigate a fresh static recording with each parameter table (plus the rough values and the truth)."""
    check_durations(align_s, duration_s, problem.rate_hz)
    sim = simulate(navigation_problem(problem, duration_s, align_s), seed=seed)
    rec = sim.recording
    sets = {"rough initial values": _rough_for(problem, seed), **tables, "truth": sim.truth.values}
    runs = [navigate_free(rec, values, align_s, label) for label, values in sets.items()]
    rows = [{"parameters": run.label, "horizontal error at end (m)": run.horizontal_m[-1],
             "horizontal error at end (nmi)": run.horizontal_m[-1] / NAUTICAL_MILE,
             "max horizontal error (nmi)": run.horizontal_m.max() / NAUTICAL_MILE} for run in runs]
    return runs, pd.DataFrame(rows)


def _rough_for(problem: Problem, seed: int) -> np.ndarray:
    """The rough initial values the paper would start from: those of a calibration recording."""
    return rough_parameters(simulate(problem, seed=seed).recording).values


def plot_navigation_check(runs: list[NavigationRun], path: str | Path, title: str) -> Path:
    """Horizontal position error of each run against time (log scale, nmi)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 5))
    for run in runs:
        ax.semilogy(run.time / 60, np.maximum(run.horizontal_m, 1e-3) / NAUTICAL_MILE, label=run.label)
    ax.axhline(1.0, color="k", ls=":", lw=0.8, label="1 nmile")
    ax.set_xlabel("time of free-inertial navigation (min)")
    ax.set_ylabel("horizontal position error (nmile)")
    legend_outside(ax, fontsize=8)
    ax.set_title(title)
    return save_figure(fig, path)


def navigation_check_files(runs: list[NavigationRun], table: pd.DataFrame, shown: pd.DataFrame, stem: Path,
                           title: str, plot_title: str) -> dict[Path, bytes]:
    """The files of a navigation check: its table as ``STEM.csv`` (full precision) and ``STEM.md`` (``shown``,
    rounded, under ``title``), and its plot ``STEM.png`` (under ``plot_title``), for
    :func:`core.files.write_files`."""
    files = frame_files(table, stem, title, display=shown)
    buffer = io.BytesIO()
    plot_navigation_check(runs, buffer, plot_title)
    files[stem.with_name(f"{stem.name}.png")] = buffer.getvalue()
    return files


def write_navigation_check(runs, table: pd.DataFrame, out_dir: str | Path, name: str) -> None:
    """The check's table (CSV, Markdown) and plot."""
    write_files(navigation_check_files(runs, table, display(table, sigmas=float_columns(table)),
                                       Path(out_dir) / f"{safe_stem(name)}-navcheck",
                                       f"{name}: 1 h static free-inertial navigation after calibration",
                                       f"{name}: horizontal position error, static base, after alignment"))
