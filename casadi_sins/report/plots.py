"""Plots people would rather look at than tables: navigated velocity, residuals, Allan deviation."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..calibrate.result import CalibrationResult
from ..core.files import atomic_write_bytes
from ..core.units import DEG_PER_H, UG
from ..data.recording import Recording
from ..nav.navigation import GroupNavigation, compensated_increments, navigate, static_velocities
from ..noise.raw import allan_deviation

def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (no screen), imported when a plot is first drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure_bytes(fig) -> bytes:
    """A matplotlib figure as PNG bytes; the figure is closed."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    pyplot().close(fig)
    return buffer.getvalue()


def legend_outside(ax, fontsize: float = 8) -> None:
    """The legend of an axes outside the plots, never over the data: right of it when it is in the last column
    of its figure, else below the whole figure in one row."""
    spec = ax.get_subplotspec()
    if spec is None or spec.is_last_col():
        ax.legend(fontsize=fontsize, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
        return
    handles, labels = ax.get_legend_handles_labels()
    ax.figure.legend(handles, labels, fontsize=fontsize, loc="upper center", bbox_to_anchor=(0.5, 0.0),
                     ncol=max(1, len(labels)), frameon=False)


def save_figure(fig, path):
    """Save a matplotlib figure as PNG (atomically to a path, or into a binary file object) and close it."""
    data = figure_bytes(fig)
    if hasattr(path, "write"):
        path.write(data)
        return path
    return atomic_write_bytes(path, data)


def plot_navigation(rec: Recording, runs: dict[str, list[GroupNavigation]], path: str | Path) -> Path:
    """Velocity error of each group for one or more parameter sets (one row per group)."""
    plt = pyplot()
    groups = rec.group_ids
    fig, axes = plt.subplots(len(groups), 3, figsize=(13, 3.0 * len(groups)), squeeze=False, sharex="row")
    for label, navs in runs.items():
        for row, nav in enumerate(navs):
            for col, name in enumerate("ENU"):
                axes[row, col].plot(nav.time, nav.velocity[:, col], lw=0.8, label=label)
                axes[row, col].set_title(f"group {nav.group}: v_{name}", fontsize=9)
    for row, group in enumerate(groups):
        for seg in rec.group_segments(group):
            if not seg.is_static:
                for col in range(3):
                    axes[row, col].axvspan(seg.start, seg.end, color="0.85", lw=0)
        axes[row, 0].set_ylabel("m/s")
    for col in range(3):
        axes[-1, col].set_xlabel("time (s)")
    legend_outside(axes[0, 0], fontsize=8)
    fig.suptitle(f"{rec.name}: navigated velocity (grey: rotations)")
    return save_figure(fig, path)


def static_residuals(rec: Recording, result: CalibrationResult) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Velocity in each static segment relative to its first sample, navigated with the result's own model.

    Returns ``{segment number: (time, velocity (n, 3))}``.  The NLP's estimated start attitudes are used
    where it has them; the ILS navigates from its alignment, as it does in its own iteration.
    """
    navs = navigate(rec, result.parameters.values, result.start_attitudes)
    return {seg.number: (t, v - v[0]) for seg, t, v in static_velocities(rec, navs)}


def plot_residuals(rec: Recording, residuals: dict[str, dict], path: str | Path) -> Path:
    """Velocity in each static interval (relative to its start), E/N/U rows, intervals side by side."""
    plt = pyplot()
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
        axes[0].text(offset + 2, 1.02, seg.orientation or "", transform=axes[0].get_xaxis_transform(), fontsize=7)
        offset += (t[-1] - t[0]) * 1.08
    for axis, label in enumerate("ENU"):
        axes[axis].set_ylabel(f"v_{label} (mm/s)")
    axes[-1].set_xlabel("time within the static intervals, laid side by side (s)")
    legend_outside(axes[0], fontsize=8)
    fig.suptitle(f"{rec.name}: velocity in each static interval after calibration (relative to its start)",
                 y=0.995)
    return save_figure(fig, path)


def residual_plot(result: CalibrationResult, rec: Recording) -> bytes:
    """Velocity in every static interval after calibration (mm/s), E/N/U, intervals side by side (PNG)."""
    buffer = io.BytesIO()
    plot_residuals(rec, {result.solver: static_residuals(rec, result)}, buffer)
    return buffer.getvalue()


def noise_plot(result: CalibrationResult, rec: Recording) -> bytes:
    """Allan deviation of the static segments' rates against the noise model's white terms (PNG)."""
    model = result.noise.model
    plt = pyplot()
    dth, dvs = [], []
    for seg in rec.static_segments:
        dth_seg, dv_seg = compensated_increments(rec, result.parameters.values, rec.segment_samples(seg))
        dth.append(dth_seg / rec.dt)
        dvs.append(dv_seg / rec.dt)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    for ax, rates, white, unit, scale, label in (
            (axes[0], dth, model.gyro_arw, "deg/h", DEG_PER_H, "gyro"),
            (axes[1], dvs, model.accel_vrw, "ug", UG, "accelerometer")):
        tau, adev = allan_deviation(rates, rec.dt)
        for axis in range(3):
            ax.loglog(tau, adev[:, axis] / scale, "o-", ms=3, lw=0.8, label=f"{label} {'xyz'[axis]}")
        ax.loglog(tau, np.mean(white) / np.sqrt(tau) / scale, "k--", lw=1, label="white noise of the model")
        ax.set_xlabel("cluster time (s)")
        ax.set_ylabel(f"Allan deviation ({unit})")
        ax.grid(True, which="both", lw=0.3)
        legend_outside(ax, fontsize=7)
    fig.suptitle(f"{rec.name}: Allan deviation of the static segments (calibrated), and the noise model")
    return figure_bytes(fig)
