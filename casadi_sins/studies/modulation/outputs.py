"""The files of ``casadi-sins modulate``: ``modulation.json``, its Markdown, and plots of the error by
source (in the manner of Guan et al. 2023, Figs. 1-6), as ``{path: bytes}`` written together."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...core.files import safe_stem
from ...core.text import markdown_text, one_line
from ...report.plots import legend_outside, figure_bytes, pyplot
from .analysis import SchemeResult

NAUTICAL_MILE = 1852.0
#: The file name of the plot of every scheme's total (a scheme may not take it).
COMPARISON = "comparison"


def _fmt(x, digits: int = 4) -> str:
    """A number for a Markdown cell ("-" for none)."""
    if x is None:
        return "-"
    if isinstance(x, float) and (x == 0 or 1e-3 <= abs(x) < 1e6):
        return f"{x:.{digits}g}"
    return f"{x:.3g}" if isinstance(x, float) else str(x)


def _plain(text) -> str:
    """Outside text for a plot title: one line, no mathtext."""
    return one_line(text).replace("$", r"\$")


def markdown(doc: dict) -> str:
    """The document as Markdown: a summary of every scheme, then each scheme's sources."""
    head = (f"# Rotation modulation: {markdown_text(doc['errors']['name'])}, {doc['hours']:g} h, "
            f"latitude {doc['latitude_deg']:g} deg")
    lines = [head,
             "", "Every number is 1 sigma of the covariance propagation (static base, vertical channel held).",
             f"Errors from {markdown_text(doc['errors']['origin'])}" + (
                 " (full covariance, correlations kept in the total)" if doc["errors"]["correlated"] else "")
             + f"; initial attitude: {markdown_text(doc['errors']['initial_attitude'])}.", "",
             "| scheme | max horizontal position (m) | (nmi) | at (h) | max velocity (m/s) | max longitude (m) "
             "| max latitude (m) | compute (s) |", "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for name, s in doc["schemes"].items():
        lines.append(f"| {markdown_text(name)} | {_fmt(s['max_horizontal_position_error_m'])} | "
                     f"{_fmt(s['max_horizontal_position_error_m'] / NAUTICAL_MILE)} | {_fmt(s['time_of_max_h'])} | "
                     f"{_fmt(s['max_velocity_error_mps'])} | {_fmt(s['max_longitude_error_m'])} | "
                     f"{_fmt(s['max_latitude_error_m'])} | {_fmt(s['compute_s'], 3)} |")
    for name, s in doc["schemes"].items():
        lines += _scheme_section(name, s)
    if doc.get("warnings"):
        lines += ["", "## Warnings", ""] + [f"- {markdown_text(w)}" for w in doc["warnings"]]
    return "\n".join(lines) + "\n"


def _scheme_section(name: str, s: dict) -> list[str]:
    """The Markdown lines of one scheme: its sources, what is not averaged away, the residual drift."""
    lines = ["", f"## {markdown_text(name)}", "", markdown_text(s["description"]) or "(no description)", "",
             f"Returns to its start attitude: {'yes' if s['returns_to_start'] else 'NO'}; "
             f"period {_fmt(s['period_s'])} s.", "",
             "| source | max position (m) | ratio to strapdown | max longitude (m) | max latitude (m) |",
             "| --- | ---: | ---: | ---: | ---: |"]
    for src, v in s["by_source"].items():
        lines.append(f"| {src} | {_fmt(v['max_position_error_m'])} | {_fmt(v['ratio_to_strapdown'], 3)} | "
                     f"{_fmt(v['max_longitude_error_m'])} | {_fmt(v['max_latitude_error_m'])} |")
    kept = s["not_averaged_away"]
    lines += ["", "Not averaged away (at least half the strapdown contribution and 1 % of the total), largest "
              "first: " + (", ".join(f"{v['name']} ({_fmt(v['max_position_error_m'])} m, " + (
                  "none under strapdown)" if v["ratio_to_strapdown"] is None
                  else f"{_fmt(v['ratio_to_strapdown'], 3)} x strapdown)") for v in kept)
                           if kept else "none") + "."]
    lines += _tilt_lines(s.get("period_mean_tilt"))
    drift = {k: v for k, v in s["residual_drift_deg_h_per_sigma"].items() if max(map(abs, v)) > 1e-7}
    if drift:
        lines += ["", "Residual constant drift one period leaves of 1 sigma of each gyro term (deg/h, E N U):", ""]
        lines += [f"- {k}: {', '.join(f'{x:+.3g}' for x in v)}" for k, v in drift.items()]
    return lines


def _tilt_lines(tilt: dict | None) -> list[str]:
    """The period-mean tilt of one scheme, largest horizontal swing first (terms of 0.1 % of the total or more)."""
    if not tilt:
        return []
    total = tilt["two_r_horizontal_total_m"]
    terms = sorted(tilt["terms"].items(), key=lambda kv: -kv[1]["two_r_horizontal_m"])
    lines = ["", f"Period-mean tilt (mean attitude error over the first period, 1 sigma): it swings the position by "
             f"about 2 R x its horizontal part; all terms together {_fmt(total)} m.", "",
             "| term | tilt E, N, U (arcsec) | 2 R x horizontal (m) |", "| --- | --- | ---: |"]
    for name, v in terms:
        if v["two_r_horizontal_m"] >= 1e-3 * max(total, 1e-9):
            lines.append(f"| {name} | {', '.join(f'{x:+.3g}' for x in v['tilt_arcsec'])} | "
                         f"{_fmt(v['two_r_horizontal_m'])} |")
    return lines


def plot_scheme(result: SchemeResult, title: str) -> bytes:
    """Longitude and latitude error by source, 1 sigma (Guan et al. 2023, Figs. 1-6, in their manner): PNG."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(14, 5), sharex=True)
    hours = result.time_h
    for axis, (row, label) in enumerate(((3, "longitude (east)"), (2, "latitude (north)"))):
        ax = axes[axis]
        for source, cov in result.by_source.items():
            sig = np.sqrt(np.clip(cov[:, row, row], 0, None))
            if sig.max() > 0:
                ax.plot(hours, sig, lw=1.0, label=source)
        ax.plot(hours, np.sqrt(np.clip(result.total[:, row, row], 0, None)), "k", lw=2.0, label="total")
        ax.set_yscale("symlog", linthresh=1.0)
        ax.set_title(f"{label} error, 1 sigma")
        ax.set_xlabel("time (h)")
        ax.set_ylabel("m")
        ax.grid(True, which="both", alpha=0.3)
    legend_outside(axes[1], fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    return figure_bytes(fig)


def plot_comparison(results: dict[str, SchemeResult], title: str) -> bytes:
    """Total horizontal position error of every scheme, 1 sigma: PNG."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 5))
    for name, res in results.items():
        tot = res.total
        ax.plot(res.time_h, np.sqrt(np.clip(tot[:, 2, 2] + tot[:, 3, 3], 0, None)), lw=1.2, label=name)
    ax.set_yscale("log")
    ax.set_ylim(bottom=1.0)
    ax.set_xlabel("time (h)")
    ax.set_ylabel("horizontal position error, 1 sigma (m)")
    ax.grid(True, which="both", alpha=0.3)
    legend_outside(ax, fontsize=8)
    ax.set_title(title)
    fig.tight_layout()
    return figure_bytes(fig)


def modulation_files(doc: dict, results: dict[str, SchemeResult], out, plots: bool = True) -> dict[Path, bytes]:
    """``modulation.json``, ``modulation.md`` and (``plots``) ``NAME.png`` per scheme and ``comparison.png``,
    as ``{path: content}`` for :func:`casadi_sins.core.files.write_files`."""
    out = Path(out)
    files = {out / "modulation.json": (json.dumps(doc, indent=1, allow_nan=False) + "\n").encode(),
             out / "modulation.md": markdown(doc).encode()}
    if plots:
        where = f"{_plain(doc['errors']['name'])}, latitude {doc['latitude_deg']:g} deg"
        for name, res in results.items():
            files[out / f"{safe_stem(name)}.png"] = plot_scheme(res, f"{name}: navigation error by source, {where}")
        files[out / f"{COMPARISON}.png"] = plot_comparison(results, f"horizontal position error, {where}")
    return files
