"""Reports at the edges: summaries, tables in natural units, Markdown, plots."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from . import parameters as P
from .io import atomic_write_bytes, write_files
from .recording import Recording
from .strapdown import GroupNavigation, static_velocities


def recording_summary(rec: Recording) -> str:
    """A human-readable account of a recording's description and data."""
    lines = [
        f"recording {rec.name} ({rec.label})",
        f"  site: latitude {math.degrees(rec.site.latitude):.6g} deg, height {rec.site.height:g} m, "
        f"gravity {rec.site.g:.9g} m/s^2 ({'given' if rec.site.gravity is not None else 'WGS-84 normal gravity'})",
        f"  data: {len(rec.time)} samples at {rec.rate_hz:g} Hz, {rec.time[0] - rec.dt:g}-{rec.time[-1]:g} s",
    ]
    for group in rec.group_ids:
        segs = rec.group_segments(group)
        chain = " ".join(s.orientation if s.is_static else f"-{s.axis}->" for s in segs)
        lines.append(f"  group {group}: {chain}  ({segs[0].start:g}-{segs[-1].end:g} s)")
    return "\n".join(lines)


def static_velocity_table(rec: Recording, navs: list[GroupNavigation]) -> pd.DataFrame:
    """Per static segment: velocity at its end and mean slope (ENU), m/s and ug-equivalent."""
    rows = []
    for seg, t, v in static_velocities(rec, navs):
        slope = np.polyfit(t - t[0], v, 1)[0]
        rows.append({"segment": seg.number, "group": seg.group, "orientation": seg.orientation,
                     "v_east_mps": v[-1, 0], "v_north_mps": v[-1, 1], "v_up_mps": v[-1, 2],
                     "slope_east_ug": slope[0] / P.UG, "slope_north_ug": slope[1] / P.UG,
                     "slope_up_ug": slope[2] / P.UG})
    return pd.DataFrame(rows)


def frame_files(frame: pd.DataFrame, stem: str | Path, title: str | None = None,
                float_format: str = "%.6g") -> dict[Path, bytes]:
    """A DataFrame as the contents of ``stem.csv`` and ``stem.md``."""
    stem = Path(stem)
    md = (f"# {title}\n\n" if title else "") + markdown_table(frame, float_format) + "\n"
    return {stem.with_name(stem.name + ".csv"): frame.to_csv(index=False, float_format=float_format).encode(),
            stem.with_name(stem.name + ".md"): md.encode()}


def write_frame(frame: pd.DataFrame, stem: str | Path, title: str | None = None, float_format: str = "%.6g"):
    """Write a DataFrame as ``stem.csv`` and ``stem.md`` (atomically)."""
    write_files(frame_files(frame, stem, title, float_format))


def markdown_table(frame: pd.DataFrame, float_format: str = "%.6g") -> str:
    """A DataFrame as a GitHub-flavoured Markdown table."""

    def fmt(x):
        if isinstance(x, (float, np.floating)):
            return "" if math.isnan(x) else float_format % x
        return str(x)

    header = "| " + " | ".join(map(str, frame.columns)) + " |"
    rule = "| " + " | ".join("---" for _ in frame.columns) + " |"
    body = ["| " + " | ".join(fmt(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([header, rule, *body])


def save_figure(fig, path):
    """Save a matplotlib figure as PNG (atomically to a path, or into a binary file object) and close it."""
    import io

    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    if hasattr(path, "write"):
        path.write(buffer.getvalue())
        return path
    return atomic_write_bytes(path, buffer.getvalue())


def plot_navigation(rec: Recording, runs: dict[str, list[GroupNavigation]], path: str | Path) -> Path:
    """Velocity error of each group for one or more parameter sets (one row per group)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{rec.name}: navigated velocity (grey: rotations)")
    return save_figure(fig, path)


def parameter_report(result, truth: P.ParameterSet | None = None) -> pd.DataFrame:
    """The calibrated parameters with sigma in natural units (and errors against a truth)."""
    params = result.parameters
    frame = pd.DataFrame({"parameter": params.names, "unit": params.units, "value": params.values,
                          "natural unit": params.natural_units, "sigma (natural)": params.natural_sigma()})
    if truth is not None:
        err = P.natural_errors(params, truth)
        frame["truth"] = truth.aligned(params.names)
        frame["error (natural)"] = err
        frame["error/sigma"] = err / frame["sigma (natural)"]
    return frame


def calibration_tables(result, stem: str | Path, name: str, truth: P.ParameterSet | None = None
                       ) -> dict[Path, bytes]:
    """Per-iteration table (the paper's Table 2 layout) and the parameter report of the recording
    ``name``, CSV + Markdown, as ``{path: content}`` (``stem-iterations.*``, ``stem-parameters.*``)."""
    files = frame_files(result.history_frame(truth), f"{stem}-iterations",
                        f"{name}: {result.solver} per iteration (errors in natural units)", "%.8g")
    files.update(frame_files(parameter_report(result, truth), f"{stem}-parameters",
                             f"{name}: {result.solver} calibration ({result.iterations} iterations, "
                             f"{result.wall_time:.2f} s). sigma: {result.sigma_meaning}", "%.6g"))
    return files
