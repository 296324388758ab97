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
from ..model.parameters import ParameterSet, truth_errors
from ..model.registry import group_of, natural_value_of
from .rounding import format_sigma, format_with_sigma, rounded, sigma_in_value_unit
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
        if all(s.is_free for s in segs):  # a session by hand: the count, not a chain of dozens of "free"
            rests = sum(s.is_static for s in segs)
            chain = f"{rests} rests at any orientation joined by {len(segs) - rests} free moves"
        else:
            chain = " ".join(s.orientation or "rest" if s.is_static else f"-{s.axis or 'move'}->" for s in segs)
        lines.append(f"  group {group}: {chain}  ({segs[0].start:g}-{segs[-1].end:g} s)")
    return "\n".join(lines)


def static_velocity_table(rec: Recording, navs: list[GroupNavigation]) -> pd.DataFrame:
    """Per static segment: velocity at its end and mean slope (ENU), m/s and ug-equivalent."""
    rows = []
    for seg, t, v in static_velocities(rec, navs):
        slope = np.polyfit(t - t[0], v, 1)[0]
        rows.append({"segment": seg.number, "group": seg.group, "orientation": seg.what,
                     "v_east_mps": v[-1, 0], "v_north_mps": v[-1, 1], "v_up_mps": v[-1, 2],
                     "slope_east_ug": slope[0] / UG, "slope_north_ug": slope[1] / UG,
                     "slope_up_ug": slope[2] / UG})
    return pd.DataFrame(rows)


def frame_files(frame: pd.DataFrame, stem: str | Path, title: str | None = None,
                float_format: str = "%.6g", display: pd.DataFrame | None = None) -> dict[Path, bytes]:
    """A DataFrame as the contents of ``stem.csv`` (every number in full precision: it is read by
    programs) and ``stem.md`` (rounded with ``float_format``: it is read by people), the latter from
    ``display`` when given (e.g. numbers as text rounded from their sigma, :mod:`report.rounding`)."""
    stem = Path(stem)
    md = (f"# {markdown_text(title)}\n\n" if title else "") + markdown_table(frame if display is None else display,
                                                                              float_format) + "\n"
    return {stem.with_name(stem.name + ".csv"): frame.to_csv(index=False).encode(),
            stem.with_name(stem.name + ".md"): md.encode()}


def write_frame(frame: pd.DataFrame, stem: str | Path, title: str | None = None, float_format: str = "%.6g",
                display: pd.DataFrame | None = None) -> None:
    """Write a DataFrame as ``stem.csv`` and ``stem.md`` (atomically; the Markdown from ``display`` when given)."""
    write_files(frame_files(frame, stem, title, float_format, display))


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
    paper = getattr(result.ils, "paper_sigma_natural", None) if getattr(result, "ils", None) else None
    if paper is not None:  # the paper's own: the last solve's formal sigma under its first-iteration weights
        frame["paper's sigma (natural)"] = paper
    if truth is not None:
        err = truth_errors(params, truth)
        frame["truth"] = [truth[n] if n in truth.names else np.nan for n in params.names]
        frame["error (natural)"] = err
        frame["error/sigma"] = err / frame["sigma (natural)"]
    return frame


def calibration_tables(result, stem: str | Path, name: str, truth: ParameterSet | None = None
                       ) -> dict[Path, bytes]:
    """Per-iteration table (the paper's Table 2 layout) and the parameter report of the recording
    ``name``, CSV + Markdown, as ``{path: content}`` (``stem-iterations.*``, ``stem-parameters.*``)."""
    files = frame_files(result.history_frame(truth), f"{stem}-iterations",
                        f"{name}: {result.solver} per iteration (errors in natural units)", "%.8g")
    report = parameter_report(result, truth)
    sigma_si = [sigma_in_value_unit(n, v, s) * (1.0 if group_of(n).relative else group_of(n).natural_scale)
                for n, v, s in zip(report["parameter"], report["value"], report["sigma (natural)"])]
    display = rounded(report.assign(_sigma=sigma_si), {"value": "_sigma", "truth": "_sigma",
                                                       "error (natural)": "sigma (natural)",
                                                       "_paper": "paper's sigma (natural)"}).drop(columns="_sigma")
    files.update(frame_files(report, f"{stem}-parameters",
                             f"{name}: {result.solver} calibration ({result.nit} iterations, "
                             f"{result.wall_time:.2f} s). sigma: {result.sigma_meaning}", "%.6g", display))
    return files


def natural_table(frame):
    """The terminal table: values and sigma in natural units (SI stays in the CSV), each value rounded to
    its sigma's second significant digit (:mod:`report.rounding`)."""
    values = [natural_value_of(name, value) for name, value in zip(frame["parameter"], frame["value"])]
    sigma = frame["sigma (natural)"]
    out = pd.DataFrame({"parameter": frame["parameter"],
                        "value": [format_with_sigma(v, sigma_in_value_unit(n, v, s))
                                  for n, (v, _), s in zip(frame["parameter"], values, sigma)],
                        "unit": [u for _, u in values],
                        "1-sigma": [format_sigma(s) for s in sigma],
                        "sigma unit": frame["natural unit"]})
    if "error (natural)" in frame:
        out["error"] = [format_with_sigma(e, s, signed=True) for e, s in zip(frame["error (natural)"], sigma)]
        out["error/sigma"] = [f"{e:+.2f}" if np.isfinite(e) else "" for e in frame["error/sigma"]]
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


def checks_frame(checks: list[dict]) -> pd.DataFrame:
    """A report's checks as people read them: name, value (3 significant digits), the accepted limit
    (``>= 0.43``, ``<= 1.22``, ``0.777 to 1.22``: the check's own :attr:`calibrate.result.Check.accepted`),
    passed (``yes`` / ``NO``) and the detail."""
    rows = []
    for c in checks:
        value = c.get("value")
        shown = f"{value:.3g}" if isinstance(value, (int, float)) and math.isfinite(value) else str(value)
        accepted = c.get("accepted")
        if accepted is None:  # a report written before checks stated their limit
            low, limit = c.get("low", 0.0), c.get("limit")
            accepted = f"<= {limit:.3g}" if not low else f"{low:.3g} to {limit:.3g}"
        rows.append({"name": c.get("name"), "value": shown, "limit": accepted,
                     "passed": "yes" if c.get("passed") else "NO", "detail": c.get("detail")})
    return pd.DataFrame(rows, columns=["name", "value", "limit", "passed", "detail"])
