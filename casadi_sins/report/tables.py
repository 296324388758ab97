"""Tables at the edges: natural units (ug, ppm, arcsec, deg/h), Markdown, CSV, terminal."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.files import write_files
from ..core.text import markdown_text, one_line
from ..core.units import UG
from ..data.recording import Recording
from ..model.noise import SensorNoise
from ..model.parameters import ParameterSet, natural_errors
from ..model.registry import natural_value_of
from ..nav.navigation import GroupNavigation, static_velocities

def recording_summary(rec: Recording) -> str:
    """A human-readable account of a recording's description and data."""
    lines = [
        f"recording {one_line(rec.name)} ({one_line(rec.label)})",
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
                     "slope_east_ug": slope[0] / UG, "slope_north_ug": slope[1] / UG,
                     "slope_up_ug": slope[2] / UG})
    return pd.DataFrame(rows)


def frame_files(frame: pd.DataFrame, stem: str | Path, title: str | None = None,
                float_format: str = "%.6g") -> dict[Path, bytes]:
    """A DataFrame as the contents of ``stem.csv`` and ``stem.md``."""
    stem = Path(stem)
    md = (f"# {markdown_text(title)}\n\n" if title else "") + markdown_table(frame, float_format) + "\n"
    return {stem.with_name(stem.name + ".csv"): frame.to_csv(index=False, float_format=float_format).encode(),
            stem.with_name(stem.name + ".md"): md.encode()}


def write_frame(frame: pd.DataFrame, stem: str | Path, title: str | None = None, float_format: str = "%.6g") -> None:
    """Write a DataFrame as ``stem.csv`` and ``stem.md`` (atomically)."""
    write_files(frame_files(frame, stem, title, float_format))


def markdown_table(frame: pd.DataFrame, float_format: str = "%.6g") -> str:
    """A DataFrame as a GitHub-flavoured Markdown table."""

    def fmt(x):
        if isinstance(x, (float, np.floating)):
            return "" if math.isnan(x) else float_format % x
        return markdown_text(x)

    header = "| " + " | ".join(markdown_text(c) for c in frame.columns) + " |"
    rule = "| " + " | ".join("---" for _ in frame.columns) + " |"
    body = ["| " + " | ".join(fmt(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([header, rule, *body])


def parameter_report(result, truth: ParameterSet | None = None) -> pd.DataFrame:
    """The calibrated parameters with sigma in natural units (and errors against a truth)."""
    params = result.parameters
    frame = pd.DataFrame({"parameter": params.names, "unit": params.units, "value": params.values,
                          "natural unit": params.natural_units, "sigma (natural)": params.natural_sigma()})
    if truth is not None:
        err = natural_errors(params, truth)
        frame["truth"] = truth.aligned(params.names)
        frame["error (natural)"] = err
        frame["error/sigma"] = err / frame["sigma (natural)"]
    return frame


def calibration_tables(result, stem: str | Path, name: str, truth: ParameterSet | None = None
                       ) -> dict[Path, bytes]:
    """Per-iteration table (the paper's Table 2 layout) and the parameter report of the recording
    ``name``, CSV + Markdown, as ``{path: content}`` (``stem-iterations.*``, ``stem-parameters.*``)."""
    files = frame_files(result.history_frame(truth), f"{stem}-iterations",
                        f"{name}: {result.solver} per iteration (errors in natural units)", "%.8g")
    files.update(frame_files(parameter_report(result, truth), f"{stem}-parameters",
                             f"{name}: {result.solver} calibration ({result.nit} iterations, "
                             f"{result.wall_time:.2f} s). sigma: {result.sigma_meaning}", "%.6g"))
    return files


def natural_table(frame):
    """The terminal table: values and sigma in natural units (SI stays in the CSV)."""
    values = [natural_value_of(name, value) for name, value in zip(frame["parameter"], frame["value"])]
    out = pd.DataFrame({"parameter": frame["parameter"],
                        "value": [f"{v:.9g}" if u == "m/s/pulse" else f"{v:.6g}" for v, u in values],
                        "unit": [u for _, u in values],
                        "1-sigma": [f"{s:.3g}" for s in frame["sigma (natural)"]],
                        "sigma unit": frame["natural unit"]})
    if "error (natural)" in frame:
        out["error"] = [f"{e:+.3g}" for e in frame["error (natural)"]]
        out["error/sigma"] = [f"{e:+.2f}" for e in frame["error/sigma"]]
    return out


def natural_noise_frame(models: dict[str, SensorNoise]) -> pd.DataFrame:
    """A table of noise models side by side (rows: term and axis; columns: the models)."""
    rows = []
    for term, key, unit in (("gyro angle random walk", "gyro_arw_deg_rth", "deg/sqrt(h)"),
                            ("accel velocity random walk", "accel_vrw_ug_rthz", "ug/sqrt(Hz)"),
                            ("gyro quantization", "gyro_quantization_arcsec", "arcsec"),
                            ("accel quantization", "accel_quantization_mm_s", "mm/s"),
                            ("gyro bias instability", "gyro_bias_instability_deg_h", "deg/h"),
                            ("accel bias instability", "accel_bias_instability_ug", "ug")):
        axes = ("x", "y", "z") if "bias" not in key else ("",)
        for k, axis in enumerate(axes):
            row = {"term": term, "axis": axis, "unit": unit}
            for label, model in models.items():
                value = model.natural()[key]
                row[label] = np.nan if value is None else float(np.atleast_1d(value)[k if axis else 0])
            rows.append(row)
    return pd.DataFrame(rows)
