"""The paper's claim measured: accuracy against the start attitude error (0.4 ... 10 deg)."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from ..data.problem import Problem
from ..model.registry import CORE_SPANS
from ..report.plots import legend_outside, pyplot, save_figure
from ..report.tables import write_frame
from . import montecarlo as MC


def start_attitude_sweep(problem: Problem, angles_deg: Sequence[float], seeds: Sequence[int],
                         solvers: Sequence[str] = ("ils",), workers: int | None = None,
                         progress=None) -> pd.DataFrame:
    """Monte Carlo rows (see :func:`montecarlo.run`) for each start attitude error."""
    frames = []
    for angle in angles_deg:
        rows = MC.run(problem.with_changes(start_attitude_deg=float(angle)), seeds, solvers, workers)
        frames.append(rows.assign(start_attitude_deg=float(angle)))
        if progress:
            progress(f"start attitude {angle:g} deg: {len(seeds)} seeds done")
    return pd.concat(frames, ignore_index=True)


def sweep_table(rows: pd.DataFrame) -> pd.DataFrame:
    """RMS error per parameter group, solver and angle: first iteration and final, in natural units."""
    ok = rows[rows["failed"] == ""]
    failed = rows[rows["failed"] != ""].groupby(["solver", "start_attitude_deg"])["seed"].nunique()

    def rms(e):
        return float(np.sqrt(np.mean(np.square(e))))

    table = ok.groupby(["solver", "start_attitude_deg", "group"], sort=False).agg(
        unit=("unit", "first"), rms_first_iteration=("first_iteration_error", rms), rms_final=("error", rms),
        max_iterations=("iterations", "max")).reset_index()
    table["failed_runs"] = [int(failed.get((s, a), 0)) for s, a in zip(table["solver"], table["start_attitude_deg"])]
    table["floor"] = [MC.NOISE_FLOOR[g][0] for g in table["group"]]
    table["final_over_floor"] = table["rms_final"] / table["floor"]
    return table


def plot_sweep(table: pd.DataFrame, path: str | Path) -> Path:
    """RMS error per group against the start attitude error, per solver."""
    plt = pyplot()
    groups = [g for g, _, _ in CORE_SPANS]
    fig, axes = plt.subplots(2, 3, figsize=(13, 7))
    for ax, group in zip(axes.ravel(), groups):
        sub = table[table["group"] == group]
        for solver, part in sub.groupby("solver"):
            ax.semilogy(part["start_attitude_deg"], part["rms_final"], "o-", label=f"{solver} final")
            if solver == "ils":
                ax.semilogy(part["start_attitude_deg"], part["rms_first_iteration"], "s--", alpha=0.6,
                            label=f"{solver} iteration 1")
        ax.axhline(MC.NOISE_FLOOR[group][0], color="k", lw=0.8, ls=":", label="noise floor")
        ax.set_title(f"{group} ({sub['unit'].iloc[0]})", fontsize=10)
        ax.set_xlabel("start attitude error (deg)")
        ax.set_xscale("log")
    legend_outside(axes[0, 0], fontsize=8)
    fig.suptitle("RMS error against the start attitude error")
    fig.tight_layout()
    return save_figure(fig, path)


def write_sweep(rows: pd.DataFrame, out_dir: str | Path, stem: str = "start-attitude-sweep") -> pd.DataFrame:
    """The sweep's rows, table and plot; returns the table."""
    out_dir = Path(out_dir)
    table = sweep_table(rows)
    write_frame(rows, out_dir / f"{stem}-runs")
    write_frame(table, out_dir / stem, "RMS error per parameter group against the start attitude error")
    plot_sweep(table, out_dir / f"{stem}.png")
    return table
