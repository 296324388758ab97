"""The design's report: ``design.md`` beside the input schedule, and a drawing of both schedules' turns."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ...data.problem import Problem
from ...report.plots import figure_bytes, pyplot
from ...report.tables import markdown_table
from .criteria import Score

AXIS_COLOURS = {"X": "tab:red", "Y": "tab:green", "Z": "tab:blue"}


def time_split(problem: Problem) -> dict[str, float]:
    """Seconds of statics, turns and handling of a problem's schedule, and in all."""
    segs = problem.segments()
    statics = sum(s.end - s.start for s in segs if s.is_static)
    turns = sum(s.end - s.start for s in segs if not s.is_static)
    total = segs[-1].end - segs[0].start
    return {"statics": statics, "turns": turns, "handling": total - statics - turns, "total": total}


def schedule_frame(problem: Problem) -> pd.DataFrame:
    """A schedule as a table: segment, group, kind, position or turn, start and duration (s)."""
    rows = []
    for s in problem.segments():
        what = s.orientation if s.is_static else f"{s.axis} {s.angle_deg:g} deg"
        rows.append({"segment": s.number, "group": s.group, "kind": s.kind, "position / turn": what,
                     "start (s)": round(s.start, 1), "duration (s)": round(s.end - s.start, 1)})
    return pd.DataFrame(rows)


def sigma_frame(names, units, reference: Score | np.ndarray, design: Score, input_name: str) -> pd.DataFrame:
    """Predicted sigma per parameter: the input schedule's, the design's and their ratio."""
    ref = reference if isinstance(reference, np.ndarray) else reference.prediction.sigma_natural
    return pd.DataFrame({"parameter": names, "natural unit": units, f"{input_name} sigma": ref,
                         "design sigma": design.prediction.sigma_natural, "ratio": design.ratios})


def drawing(problems: list[Problem]) -> bytes:
    """PNG: each schedule on a time line, statics labelled with their position, turns coloured by axis."""
    plt = pyplot()
    fig, axes = plt.subplots(len(problems), 1, figsize=(13, 1.9 * len(problems) + 0.6), squeeze=False)
    for ax, problem in zip(axes[:, 0], problems):
        for s in problem.segments():
            if s.is_static:
                ax.broken_barh([(s.start, s.end - s.start)], (0, 1), color="0.85", edgecolor="0.4")
                ax.text(0.5 * (s.start + s.end), 0.5, s.orientation, ha="center", va="center", fontsize=7,
                        rotation=90)
            else:
                colour = AXIS_COLOURS[s.axis[1]]
                ax.broken_barh([(s.start, s.end - s.start)], (0, 1), color=colour)
                ax.text(0.5 * (s.start + s.end), 1.08, f"{s.axis}{s.angle_deg:g}", ha="center", va="bottom",
                        fontsize=6, color=colour, rotation=90)
        ax.set_ylim(0, 1.9)
        ax.set_yticks([])
        ax.set_title(f"{problem.name}: {len(problem.segments())} segments, {problem.duration:.0f} s", fontsize=9)
    axes[-1, 0].set_xlabel("time (s); turns coloured by body axis: X red, Y green, Z blue")
    fig.tight_layout()
    return figure_bytes(fig)


#: What the prediction is, and for which solver it holds.
SOLVER_WORDS = ("Predicted 1-sigma from the same error model as `analyze` (covariance of the NLP's linearisation "
                "whitened by the stated noise), natural units. **The prediction, the ratios and the cap hold for "
                "the NLP** (the default solver, which estimates each group's start attitude); the paper's ILS "
                "aligns each group on its first position and can be much less precise on a schedule of few "
                "groups: `design --solvers nlp ils` adds its own predicted sigma.")


def ils_lines(names, ils: dict[str, np.ndarray], base_name: str) -> list[str]:
    """The ILS's predicted sigma on both schedules, in a sentence (Markdown list lines)."""
    ratio = ils["design"] / ils["input"]
    worst = int(np.argmax(ratio))
    return [f"- ILS (the paper's method) on the design: geometric-mean sigma ratio against {base_name} "
            f"**{float(np.exp(np.mean(np.log(ratio)))):.3f}**, worst {names[worst]} at **{ratio[worst]:.3f}** x "
            "(its own prediction: the equations' covariance with the second order of its alignment)"]


def markdown(base: Problem, design: Problem, ref_score: Score, score: Score, settings: dict[str, str],
             extra: list[str], png_name: str, ils: dict[str, np.ndarray] | None = None) -> str:
    """The text of ``design.md`` (``ils``: the ILS's predicted sigma on the ``"input"`` and the ``"design"``)."""
    names, units = score.prediction.nominal.names, score.prediction.nominal.natural_units
    sig = sigma_frame(names, units, ref_score, score, base.name)
    if ils is not None:
        sig[f"ILS {base.name} sigma"] = ils["input"]
        sig["ILS design sigma"] = ils["design"]
        sig["ILS ratio"] = ils["design"] / ils["input"]
        extra = extra + ils_lines(names, ils, base.name)
    times = pd.DataFrame([{"schedule": p.name, **{k: round(v, 1) for k, v in time_split(p).items()},
                           "positions": len([s for s in p.segments() if s.is_static])} for p in (base, design)])
    lines = [f"# Designed calibration schedule for {base.name}", "", SOLVER_WORDS, "",
             "| setting | value |", "| --- | --- |"] + [f"| {k} | {v} |" for k, v in settings.items()] + [
        "", "## Result", "",
        f"- criterion value (log ratio against {base.name}): design {score.value:+.4f}, input {ref_score.value:+.4f}",
        f"- geometric-mean sigma ratio over the {len(names)} parameters: **{score.geometric_mean:.3f}**",
        f"- worst parameter: {names[int(np.argmax(score.ratios))]} at **{score.ratios.max():.3f}** x the input's",
        *extra, "", "## Time (s)", "", markdown_table(times, "%.1f"), "",
        "## Predicted sigma per parameter", "", markdown_table(sig, "%.4g"), "",
        f"## Schedules\n\n![turns]({png_name})", "", f"### {base.name} (input)", "",
        markdown_table(schedule_frame(base)), "", f"### {design.name} (design)", "",
        markdown_table(schedule_frame(design)), ""]
    return "\n".join(lines)
